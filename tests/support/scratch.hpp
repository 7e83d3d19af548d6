#pragma once
/// Shared helpers of the scenario tests: a scratch directory removed at scope exit, and the
/// registry filled once by physics::register_all.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>
#include <unistd.h>

#include "engine/model/registry.hpp"
#include "physics/register_all.hpp"

namespace sparkdem::test {

/// A fresh directory under the system temp directory, removed at scope exit.
struct ScratchDir {
  std::filesystem::path path;
  explicit ScratchDir(const std::string& prefix = "sparkdem_test") {
    static std::atomic<int> counter{0};
    path = std::filesystem::temp_directory_path() /
           (prefix + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++) + "_" +
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

/// Every law, module and generator, registered once.
inline const Registry& registry() {
  static const Registry reg = [] {
    Registry r;
    physics::register_all(r);
    return r;
  }();
  return reg;
}

}  // namespace sparkdem::test
