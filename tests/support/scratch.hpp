#pragma once
#include <nlohmann/json.hpp>
#include <fstream>
#include <catch2/catch.hpp>
/// Shared helpers of the scenario tests: a scratch directory removed at scope exit, and the
/// registry filled once by physics::register_all.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <unistd.h>

#include "engine/model/registry.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace sparkdem::test {

/// A fresh directory under the system temp directory, removed at scope exit.
struct ScratchDir {
  std::filesystem::path path;
  explicit ScratchDir(const std::string& prefix = "sparkdem_test") {
    static std::atomic<int> counter{0};
    path = std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
                                                     std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    std::filesystem::create_directories(path);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

/// A path in single quotes for a shell command line (the scratch paths hold no quote). Built by
/// appending: `"'" + p.string()` trips GCC 12's -Wstringop-overflow false positive once inlined
/// into a unity batch.
inline std::string shell_quoted(const std::filesystem::path& p) {
  std::string s = "'";
  s += p.string();
  s += "'";
  return s;
}

/// Every law, module and generator, registered once.
inline const Registry& registry() {
  static const Registry reg = [] {
    Registry r;
    physics::register_all(r);
    return r;
  }();
  return reg;
}

/// Load `scene` (relative paths against `base`) and run it quietly on `threads` threads into
/// `outdir`, from the checkpoint `restart` if given; the run's summary.
inline nlohmann::json run_scene(const nlohmann::json& scene, const std::filesystem::path& base, const std::filesystem::path& outdir,
                                const std::optional<std::filesystem::path>& restart = {}, int threads = 1) {
  io::Scenario sc = io::load_scenario(scene, registry(), base);
  io::RunOptions opt;
  opt.outdir = outdir;
  opt.restart = restart;
  opt.quiet = true;
  opt.threads = threads;
  return io::run_scenario(sc, opt);
}

/// A scene of tests/scenario/data, parsed.
inline nlohmann::json load_data(const std::string& name) {
  std::ifstream in(std::filesystem::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data" / name);
  REQUIRE(in);
  return nlohmann::json::parse(in);
}

/// Write a scene to dir/name and return the path.
inline std::filesystem::path write_scene(const std::filesystem::path& dir, const std::string& name, const nlohmann::json& j) {
  const std::filesystem::path f = dir / name;
  std::ofstream(f) << j.dump(2);
  return f;
}

}  // namespace sparkdem::test
