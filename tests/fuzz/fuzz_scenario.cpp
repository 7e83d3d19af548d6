/// libFuzzer harness for the scenario loader: bytes -> JSON -> io::load_scenario.
/// Parse errors, ConfigError and SetupError are the expected outcomes of bad input; any other
/// exception escapes and is reported by libFuzzer as a crash, as are ASan findings.
///
/// Build (clang only): CC=clang CXX=clang++ cmake -S . -B build-fuzz -G Ninja \
///   -DSPARKDEM_FUZZ=ON -DSPARKDEM_BUILD_TESTS=OFF -DSPARKDEM_BUILD_BENCHMARKS=OFF && ninja -C build-fuzz fuzz_scenario
/// Run:  mkdir -p corpus && cp configs/*.json tests/scenario/data/*.json corpus/ &&
///       build-fuzz/fuzz_scenario corpus -max_total_time=300 -rss_limit_mb=4096
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const sparkdem::Registry reg = [] {
    sparkdem::Registry r;
    sparkdem::physics::register_all(r);
    return r;
  }();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(data, data + size);
  } catch (const nlohmann::json::exception&) {  // as io::read_json_file: parse_error, or out_of_range (1e400)
    return 0;
  }
  try {
    // Relative file names (CSV tables, snapshots) resolve against a directory that does not exist.
    (void)sparkdem::io::load_scenario(j, reg, "/nonexistent-sparkdem-fuzz");
  } catch (const sparkdem::ConfigError&) {
  } catch (const sparkdem::SetupError&) {}
  return 0;
}
