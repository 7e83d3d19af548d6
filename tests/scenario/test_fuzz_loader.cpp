/// Deterministic mutation fuzzing of the scenario loader (in process, no simulation).
///
/// Starting from every configs/*.json and tests/scenario/data/*.json, 500 seeded random
/// mutations each (delete a key or element, replace a value by another type / NaN / inf / huge /
/// negative / empty / deeply nested value, duplicate array elements, rename keys, move subtrees,
/// scale numbers, truncate the text) are fed to io::load_scenario.
/// Invariant: loading either succeeds or throws one of the typed errors (json parse error for
/// truncated text, ConfigError, SetupError) within one second; any other exception is a bug.
#include <catch2/catch.hpp>

#include "support/child_process.hpp"
#include "support/json_mutator.hpp"
#include "support/mock_modules.hpp"
#include "support/scratch.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace test_fuzz_loader {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Ptr = json::json_pointer;

/// Every registered law, module and generator plus the test mocks (scenes in tests/scenario/data
/// may use the mock modules of the contract tests).
const sparkdem::Registry& registry() {
  static const sparkdem::Registry reg = sparkdem::test::registry_with_mocks();
  return reg;
}

std::vector<fs::path> seed_files() {
  std::vector<fs::path> files;
  for (const char* dir : {"configs", "tests/scenario/data"})
    for (const auto& e : fs::directory_iterator(fs::path(SPARKDEM_SOURCE_DIR) / dir))
      if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

using Mutator = sparkdem::test::JsonMutator;

/// 500 seeded mutations of one seed file (SPARKDEM_FUZZ_MUTATIONS / SPARKDEM_FUZZ_SEED override
/// the count and seed for longer exploration); the mutator's seed depends on the file name only.
void fuzz_file(const fs::path& file) {
  const int kMutations = std::getenv("SPARKDEM_FUZZ_MUTATIONS") ? std::atoi(std::getenv("SPARKDEM_FUZZ_MUTATIONS")) : 500;
  const std::uint64_t seed = std::getenv("SPARKDEM_FUZZ_SEED") ? std::strtoull(std::getenv("SPARKDEM_FUZZ_SEED"), nullptr, 10) : 0x5eed0000u;
  INFO("seed file " << file.filename().string());
  std::ifstream in(file);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  const json original = json::parse(text);
  // The unmutated scene loads (the mutations start from a valid scenario).
  CHECK_NOTHROW(sparkdem::io::load_scenario(original, registry(), file.parent_path()));

  Mutator mut(seed + std::hash<std::string>{}(file.filename().string()) % 1000);
  int accepted = 0, rejected = 0, unparsable = 0;
  for (int k = 0; k < kMutations; ++k) {
    json j = original;
    std::string what;
    bool parsed = true;
    if (mut.pick(10) == 0) {  // truncate the text
      const std::size_t cut = mut.pick(text.size());
      what = "truncate at byte " + std::to_string(cut);
      try {
        j = json::parse(text.substr(0, cut));
      } catch (const json::parse_error&) {
        parsed = false;
        ++unparsable;
      }
    } else {
      const std::size_t n = 1 + mut.pick(3);
      for (std::size_t q = 0; q < n; ++q) what += mut.mutate(j) + "; ";
    }
    if (!parsed) continue;
    const auto t0 = std::chrono::steady_clock::now();
    std::string failure;
    try {
      (void)sparkdem::io::load_scenario(j, registry(), file.parent_path());
      ++accepted;
    } catch (const sparkdem::ConfigError&) { ++rejected; } catch (const sparkdem::SetupError&) {
      ++rejected;
    } catch (const std::exception& e) { failure = std::string("untyped exception: ") + e.what(); }
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (secs > 1.0) failure += " took " + std::to_string(secs) + " s";

    if (!failure.empty()) {
      INFO("mutation " << k << ": " << what << "\n" << failure);
      CHECK(failure.empty());
    }
  }
  // Most mutations must be caught: a loader that accepted everything would pass the loop above.
  CHECK(rejected > kMutations / 4);
  CHECK(accepted + rejected + unparsable == kMutations);
}

/// The seed files are spread over kShards test cases (every kShards-th file of the sorted list,
/// each test case its own ctest entry: ~45 s in one piece under load); together they are all.
constexpr std::size_t kShards = 3;
void fuzz_shard(std::size_t shard) {
  const auto files = seed_files();
  REQUIRE(files.size() >= 3);
  for (std::size_t k = shard; k < files.size(); k += kShards) fuzz_file(files[k]);
}
}  // namespace

TEST_CASE("the scenario loader survives 500 seeded mutations of every example scene (shard 1 of 3: every third seed file)",
          "[fuzz][scenario]") {
  fuzz_shard(0);
}

TEST_CASE("the scenario loader survives 500 seeded mutations of every example scene (shard 2 of 3: every third seed file)",
          "[fuzz][scenario]") {
  fuzz_shard(1);
}

TEST_CASE("the scenario loader survives 500 seeded mutations of every example scene (shard 3 of 3: every third seed file)",
          "[fuzz][scenario]") {
  static_assert(kShards == 3, "one test case per shard");
  fuzz_shard(2);
}

TEST_CASE("the scenario loader refuses special files and huge stage lists quickly (inputs that hung it under fuzzing)",
          "[fuzz][scenario]") {
  // Found by tools/fuzz.sh (loader campaign): "$include" or a size-distribution "csv" naming
  // /dev/zero read for ever; 100000 stages took minutes to diagnose entry by entry; a
  // from_snapshot name longer than the file system allows threw std::filesystem_error; 100000
  // sweep values took over 10 s to bind. Each input
  // runs in a forked child with a 10 s limit, so a regression fails instead of hanging CI.
  const fs::path data = fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data";
  std::ifstream in(data / "gen_relax_cylinder_psd.json");
  const json psd = json::parse(in);
  std::vector<std::pair<std::string, json>> inputs;
  json inc = psd;
  inc["contact"]["$include"] = "/dev/zero";
  inputs.emplace_back("$include of /dev/zero", inc);
  json dir = psd;
  dir["contact"]["$include"] = "/";
  inputs.emplace_back("$include of a directory", dir);
  json csv = psd;
  csv["stages"][0]["generator"]["size_distribution"] = {{"type", "table"}, {"csv", "/dev/zero"}};
  inputs.emplace_back("size distribution csv /dev/zero", csv);
  json long_name = psd;
  long_name["stages"][0]["from_snapshot"] = std::string(5000, 'n');  // was std::filesystem_error (name too long)
  inputs.emplace_back("from_snapshot with a 5000-character name", long_name);
  json many = psd;
  many["stages"] = json::array();
  for (int k = 0; k < 100000; ++k) many["stages"].push_back(1.0);
  inputs.emplace_back("100000 stages", many);
  {  // tools/fuzz.sh loader case 65352: 100000 sweep values took over 10 s to bind
    std::ifstream cin(fs::path(SPARKDEM_SOURCE_DIR) / "configs/conductivity_packing.json");
    json sweep = json::parse(cin);
    json& values = sweep["stages"][1]["sweep"]["values"];
    REQUIRE(values.is_array());
    values = json::array();
    for (int k = 0; k < 100000; ++k) values.push_back("holm");
    inputs.emplace_back("100000 sweep values", sweep);
  }
  for (const auto& [what, j] : inputs) {
    INFO(what);
    const sparkdem::test::ChildResult r = sparkdem::test::run_in_child(
        [&] {
          try {
            (void)sparkdem::io::load_scenario(j, registry(), data);
          } catch (const sparkdem::ConfigError& e) {
            sparkdem::test::child_message(e.what());
            return 2;
          } catch (const std::exception& e) {
            sparkdem::test::child_message(e.what());
            return 5;
          }
          return 0;
        },
        10, std::size_t{3} << 30);
    INFO(r.message.substr(0, 500));
    CHECK(r.kind == sparkdem::test::ChildResult::Kind::Exited);
    CHECK(r.exit_code == 2);
    CHECK(r.seconds < 5.0);
  }
}

}  // namespace test_fuzz_loader
