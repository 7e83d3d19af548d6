#pragma once
// What the binary was built from (generated at build time by tools/build_info.cmake): the git
// commit and whether the work tree's tracked files were unchanged. `sparkdem --version` prints it,
// summary.json records it, and tools/validate.py refuses to record figures from a dirty build.
#include <string>

namespace sparkdem::io {

struct BuildInfo {
  std::string commit;  ///< full git commit hash, or "unknown" outside a git checkout
  bool clean;          ///< no tracked file differed from the commit when the binary was built
};

BuildInfo build_info();

/// "commit <hash> (clean)" or "commit <hash> (dirty work tree)".
inline std::string build_info_text() {
  BuildInfo b = build_info();
  return "commit " + b.commit + (b.clean ? " (clean)" : " (dirty work tree)");
}

}  // namespace sparkdem::io
