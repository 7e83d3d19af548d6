#pragma once
/// Typed errors. Library code throws these; only main() prints and exits.
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/core/types.hpp"

namespace sparkdem {

/// One configuration problem at a JSON pointer ("/stages/0/stop/time").
struct Diagnostic {
  std::string path;     ///< JSON pointer of the offending value
  std::string message;  ///< what was expected and what was found
};

/// Invalid scenario: carries every problem found, reported together (exit code 2).
class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<Diagnostic> d)
      : std::runtime_error(format(d)), diagnostics_(std::move(d)) {}
  ConfigError(std::string path, std::string message)
      : ConfigError(std::vector<Diagnostic>{{std::move(path), std::move(message)}}) {}
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }

 private:
  static std::string format(const std::vector<Diagnostic>& d) {
    std::string s = std::to_string(d.size()) + " configuration error(s):";
    for (const auto& x : d) s += "\n  " + (x.path.empty() ? std::string("/") : x.path) + ": " + x.message;
    return s;
  }
  std::vector<Diagnostic> diagnostics_;
};

/// A run that cannot be set up from a valid scenario (unreadable file, bad snapshot, ...).
class SetupError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The physics went wrong during a run: NaN, blow-up, step above the stable step.
class PhysicsError : public std::runtime_error {
 public:
  PhysicsError(Step step, std::vector<Id> ids, std::string quantity, const std::string& what)
      : std::runtime_error(format(step, ids, quantity, what)), step_(step), ids_(std::move(ids)),
        quantity_(std::move(quantity)) {}
  Step step() const { return step_; }
  const std::vector<Id>& ids() const { return ids_; }
  const std::string& quantity() const { return quantity_; }

 private:
  static std::string format(Step step, const std::vector<Id>& ids, const std::string& q, const std::string& w) {
    // Built by appending: GCC 12 gives a false -Wrestrict on `"literal" + std::string&&` once
    // this is inlined into some callers.
    std::string s = "physics error at step ";
    s.append(std::to_string(step)).append(" in ").append(q).append(": ").append(w);
    if (!ids.empty()) {
      s += " (particle ids";
      for (std::size_t k = 0; k < ids.size() && k < 10; ++k) {
        s += ' ';  // (not " " + to_string(): GCC 12 reports a false -Wrestrict on it)
        s += std::to_string(ids[k]);
      }
      if (ids.size() > 10) s += " ...";
      s += ")";
    }
    return s;
  }
  Step step_;
  std::vector<Id> ids_;
  std::string quantity_;
};

/// Thrown when a run stops on SIGINT/SIGTERM after writing its checkpoint.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace sparkdem
