#pragma once
/// Cooperative interruption: main() installs SIGINT/SIGTERM handlers that set this flag; the
/// stage loop polls it, writes a checkpoint and throws Interrupted.
#include <atomic>

namespace sparkdem {
inline std::atomic<bool>& interrupt_flag() {
  static std::atomic<bool> flag{false};
  return flag;
}
}  // namespace sparkdem
