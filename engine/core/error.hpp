#pragma once
/// Typed errors. Library code throws these; only main() prints and exits.
#include <cstdio>
#include <limits>
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
  explicit ConfigError(std::vector<Diagnostic> d) : std::runtime_error(format(d)), diagnostics_(std::move(d)) {}
  ConfigError(std::string path, std::string message) : ConfigError(std::vector<Diagnostic>{{std::move(path), std::move(message)}}) {}
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

/// Optional details of a PhysicsError (the run watchdog fills them, engine/watchdog.hpp): when,
/// how far beyond which bound, what to change, and where the last healthy state was saved.
struct PhysicsErrorDetail {
  double time = std::numeric_limits<double>::quiet_NaN();   ///< [s] simulated time of `step` (NaN: not given)
  double value = std::numeric_limits<double>::quiet_NaN();  ///< the offending value (unit of the quantity)
  double bound = std::numeric_limits<double>::quiet_NaN();  ///< the bound it broke (same unit)
  std::string hint;                                         ///< what the user should change
  std::string checkpoint;                                   ///< file holding the last state that passed the watchdog ("" if none)
  Step checkpoint_step = -1;                                ///< the step of that state (-1: none)
};

/// The physics went wrong during a run: NaN, blow-up, step above the stable step.
/// what() = "physics error at step S [(t = T s)] in QUANTITY: REASON (particle ids a b c ... [, N in all])
///          [. To fix: HINT][. Last healthy state (step K): FILE, loadable with --restart]".
class PhysicsError : public std::runtime_error {
 public:
  PhysicsError(Step step, std::vector<Id> ids, std::string quantity, const std::string& what)
      : PhysicsError(step, std::move(ids), std::move(quantity), what, PhysicsErrorDetail{}) {}
  PhysicsError(Step step, std::vector<Id> ids, std::string quantity, const std::string& what, PhysicsErrorDetail detail)
      : std::runtime_error(format(step, ids, quantity, what, detail)),
        step_(step),
        ids_(std::move(ids)),
        quantity_(std::move(quantity)),
        reason_(what),
        detail_(std::move(detail)) {}
  Step step() const { return step_; }
  /// The particles involved, most severe first (all of them; the message prints the first 10).
  const std::vector<Id>& ids() const { return ids_; }
  const std::string& quantity() const { return quantity_; }
  /// The reason alone, without the step, quantity, ids, hint and checkpoint of what().
  const std::string& reason() const { return reason_; }
  const PhysicsErrorDetail& detail() const { return detail_; }

 private:
  static std::string format(Step step, const std::vector<Id>& ids, const std::string& q, const std::string& w, const PhysicsErrorDetail& d) {
    // Built by appending: GCC 12 gives a false -Wrestrict on `"literal" + std::string&&` once
    // this is inlined into some callers.
    std::string s = "physics error at step ";
    s.append(std::to_string(step));
    if (d.time == d.time) {  // not NaN
      char buf[40];
      std::snprintf(buf, sizeof buf, " (t = %.6g s)", d.time);
      s.append(buf);
    }
    s.append(" in ").append(q).append(": ").append(w);
    if (!ids.empty()) {
      s += " (particle ids";
      for (std::size_t k = 0; k < ids.size() && k < 10; ++k) {
        s += ' ';  // (not " " + to_string(): GCC 12 reports a false -Wrestrict on it)
        s += std::to_string(ids[k]);
      }
      if (ids.size() > 10) {
        s += " ..., ";
        s += std::to_string(ids.size());
        s += " in all";
      }
      s += ")";
    }
    if (!d.hint.empty()) s.append(". To fix: ").append(d.hint);
    if (!d.checkpoint.empty()) {
      s.append(". Last healthy state (step ").append(std::to_string(d.checkpoint_step)).append("): ");
      s.append(d.checkpoint).append(", loadable with --restart");
    }
    return s;
  }
  Step step_;
  std::vector<Id> ids_;
  std::string quantity_;
  std::string reason_;
  PhysicsErrorDetail detail_;
};

/// Thrown when a run stops on SIGINT/SIGTERM after writing its checkpoint.
class Interrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace sparkdem
