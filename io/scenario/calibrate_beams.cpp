#include "io/scenario/calibrate_beams.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/core/format.hpp"
#include "engine/core/numbers.hpp"
#include "io/scenario/json_binder.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

/// Reads one member of an object with its checks; records every problem instead of stopping.
struct Reader {
  const json& j;
  std::string path;
  std::vector<Diagnostic>& errors;

  const json* get(const char* key, bool required) const {
    if (!j.is_object() || !j.contains(key)) {
      if (required) errors.push_back({path + "/" + key, "expected a value, found none (required)"});
      return nullptr;
    }
    return &j[key];
  }
  std::optional<double> number(const char* key, bool required, double lo, double hi, bool lo_open, bool hi_open,
                               const std::string& what) const {
    const json* v = get(key, required);
    if (!v) return std::nullopt;
    if (!v->is_number()) {
      errors.push_back({path + "/" + key, "expected " + what + ", found " + describe(*v)});
      return std::nullopt;
    }
    const double x = v->get<double>();
    const bool ok = std::isfinite(x) && (lo_open ? x > lo : x >= lo) && (hi_open ? x < hi : x <= hi);
    if (!ok) {
      errors.push_back({path + "/" + key, "expected " + what + ", found " + format_number(x)});
      return std::nullopt;
    }
    return x;
  }
  std::optional<std::string> text(const char* key, bool required, const std::string& what) const {
    const json* v = get(key, required);
    if (!v) return std::nullopt;
    if (!v->is_string() || v->get<std::string>().empty()) {
      errors.push_back({path + "/" + key, "expected " + what + ", found " + describe(*v)});
      return std::nullopt;
    }
    return v->get<std::string>();
  }
  void only(std::initializer_list<const char*> keys) const {
    if (!j.is_object()) return;
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key().starts_with('$')) continue;  // annotations ($comment)
      if (std::none_of(keys.begin(), keys.end(), [&](const char* k) { return it.key() == k; })) {
        std::string list;
        for (const char* k : keys) list += std::string(list.empty() ? "" : ", ") + k;
        errors.push_back({path + "/" + it.key(), "unknown key (expected one of: " + list + ")"});
      }
    }
  }
};

constexpr double kUnbreakable = 1e30;  ///< [Pa] strength of the measuring runs (criterion stress measured, no break)

double final_value(const json& stage, const std::string& column) {
  if (!stage.contains("final") || !stage["final"].contains(column) || !stage["final"][column].is_number())
    return std::numeric_limits<double>::quiet_NaN();
  return stage["final"][column].get<double>();
}

/// Summary entry of the last stage called `name`.
const json* stage_entry(const json& summary, const std::string& name) {
  const json* found = nullptr;
  for (const auto& st : summary["stages"])
    if (st.contains("name") && st["name"] == name) found = &st;
  return found;
}

json run_scene(const json& scene, const fs::path& scene_dir, const Registry& reg, const fs::path& out, int threads) {
  Scenario sc = load_scenario(scene, reg, scene_dir);
  std::error_code ec;
  fs::remove_all(out, ec);  // a run left by an earlier calibration: start afresh
  RunOptions o;
  o.outdir = out;
  o.quiet = true;
  o.threads = threads;
  return run_scenario(sc, o);
}

/// Next radius ratio from the history (r_k, f_k = nu_k - nu_target), see the header.
double next_radius_ratio(const std::vector<double>& r, const std::vector<double>& f) {
  const std::size_t k = r.size() - 1;
  double lo = -kInf, hi = kInf;  // bracket: the r's closest to the target from either side
  double flo = 0.0, fhi = 0.0;
  for (std::size_t i = 0; i <= k; ++i) {
    if (f[i] > 0.0 && (lo == -kInf || std::abs(f[i]) < std::abs(flo))) {
      lo = r[i];
      flo = f[i];
    }
    if (f[i] < 0.0 && (hi == kInf || std::abs(f[i]) < std::abs(fhi))) {
      hi = r[i];
      fhi = f[i];
    }
  }
  double next;
  if (k == 0 || f[k] == f[k - 1] || r[k] == r[k - 1]) {
    next = r[k] * (1.0 + 0.25 * (f[k] > 0.0 ? 1.0 : -1.0));
  } else {
    next = r[k] - f[k] * (r[k] - r[k - 1]) / (f[k] - f[k - 1]);
  }
  next = std::clamp(next, 0.5 * r[k], 2.0 * r[k]);
  if (std::isfinite(lo) && std::isfinite(hi)) {
    // Points on both sides: stay inside the bracket (regula falsi on its ends if the secant left it).
    const double a = std::min(lo, hi), b = std::max(lo, hi);
    if (!(next > a && next < b)) next = lo - flo * (hi - lo) / (fhi - flo);
    if (!(next > a && next < b)) next = 0.5 * (a + b);
  }
  return next;
}

/// E_mu for the next radius ratio: E_M = E_mu g(r~) with g(r~) = E_M / E_mu measured at the
/// iterations, extrapolated as a power law g ~ r~^p from the last iteration (p from the last
/// two iterations, 2 with one: the axial stiffness E S / L0 ~ r~^2), so that E_M(r_next) hits
/// the target: E_next = E_target / g(r_next). With r_next = r_k this is E_k E_target / E_M.
double next_young_modulus(const std::vector<double>& r, const std::vector<double>& g, double r_next, double E_target) {
  const std::size_t k = r.size() - 1;
  double p = 2.0;
  if (k > 0 && r[k] != r[k - 1] && g[k] > 0.0 && g[k - 1] > 0.0) p = std::log(g[k] / g[k - 1]) / std::log(r[k] / r[k - 1]);
  p = std::clamp(p, 0.0, 6.0);  // a noisy pair of close points must not extrapolate wildly
  return E_target / (g[k] * std::pow(r_next / r[k], p));
}

}  // namespace

CalibrationSpec parse_calibration(const json& j, const fs::path& base_dir) {
  std::vector<Diagnostic> errors;
  if (!j.is_object()) throw ConfigError("", "expected a calibration object {scenario, stage, targets, initial, ...}, found " + describe(j));
  CalibrationSpec c;
  Reader top{j, "", errors};
  top.only({"scenario", "stage", "targets", "initial", "tolerance", "max_iterations", "write", "check_break"});
  if (auto s = top.text("scenario", true, "the tension scene's file name (string)")) {
    c.scenario = base_dir / *s;
    if (!fs::is_regular_file(c.scenario))
      errors.push_back({"/scenario", "expected an existing file, found none at '" + c.scenario.string() + "'"});
  }
  if (auto s = top.text("stage", true, "the name of the tension stage (string)")) c.stage = *s;
  if (auto s = top.text("write", true, "the params file to write (string)")) c.write = base_dir / *s;
  if (auto x = top.number("tolerance", false, 0.0, 1.0, true, true, "a relative tolerance in (0, 1)")) c.tolerance = *x;
  if (const json* v = top.get("max_iterations", false)) {
    if (!v->is_number_integer() || v->get<std::int64_t>() < 1 || v->get<std::int64_t>() > 1000)
      errors.push_back({"/max_iterations", "expected an integer in [1, 1000], found " + describe(*v)});
    else
      c.max_iterations = static_cast<int>(v->get<std::int64_t>());
  }
  if (auto s = top.text("check_break", false, "the name of the loading stage of the break check (string)")) c.check_break = *s;
  if (const json* t = top.get("targets", true)) {
    if (!t->is_object()) {
      errors.push_back({"/targets", "expected an object {young_modulus, poisson_ratio, tensile_strength}, found " + describe(*t)});
    } else {
      Reader r{*t, "/targets", errors};
      r.only({"young_modulus", "poisson_ratio", "tensile_strength"});
      if (auto x = r.number("young_modulus", true, 0.0, kInf, true, true, "E_M > 0 [Pa]")) c.target_young_modulus = *x;
      if (auto x = r.number("poisson_ratio", true, -1.0, 0.5, true, true, "nu_M in (-1, 0.5), finite and non-zero")) {
        if (*x == 0.0) errors.push_back({"/targets/poisson_ratio", "expected a non-zero nu_M (its relative error is used), found 0"});
        c.target_poisson_ratio = *x;
      }
      if (auto x = r.number("tensile_strength", true, 0.0, kInf, true, true, "sigma_t > 0 [Pa]")) c.target_tensile_strength = *x;
    }
  }
  if (const json* t = top.get("initial", true)) {
    if (!t->is_object()) {
      errors.push_back({"/initial", "expected an object {radius_ratio, young_modulus}, found " + describe(*t)});
    } else {
      Reader r{*t, "/initial", errors};
      r.only({"radius_ratio", "young_modulus"});
      if (auto x = r.number("radius_ratio", true, 0.0, kInf, true, true, "r~ > 0")) c.initial_radius_ratio = *x;
      if (auto x = r.number("young_modulus", true, 0.0, kInf, true, true, "E_mu > 0 [Pa]")) c.initial_young_modulus = *x;
    }
  }
  if (!errors.empty()) throw ConfigError(std::move(errors));
  return c;
}

namespace {

/// The scene must bond with cohesive_beam under a failure criterion (its stress is measured) and
/// have the calibrated stage; throws ConfigError naming what is missing.
void check_calibration_scene(const json& scene, const CalibrationSpec& spec) {
  std::vector<Diagnostic> errors;
  const std::string where = "(scenario '" + spec.scenario.string() + "') ";
  if (!scene.is_object() || !scene.contains("bonds") || !scene["bonds"].is_object() || scene["bonds"].value("law", "") != "cohesive_beam")
    errors.push_back({"/bonds/law", where + "expected \"cohesive_beam\", found another law or none"});
  else if (!scene["bonds"].contains("params") || !scene["bonds"]["params"].is_object())
    errors.push_back({"/bonds/params", where + "expected an object of cohesive_beam parameters, found none"});
  else {
    const json& bp = scene["bonds"]["params"];
    const std::string failure = bp.value("failure", "none");
    if (failure == "none")
      errors.push_back({"/bonds/params/failure", where + "expected a failure criterion (max_normal, von_mises, tresca) whose "
                                                         "stress is calibrated, found none"});
  }
  bool has_stage = false;
  if (scene.is_object() && scene.contains("stages") && scene["stages"].is_array())
    for (const auto& st : scene["stages"])
      if (st.is_object() && st.value("name", "") == spec.stage) has_stage = true;
  if (!has_stage) errors.push_back({"/stages", where + "expected a stage named '" + spec.stage + "', found none"});
  if (!errors.empty()) throw ConfigError(std::move(errors));
}

/// `check_break`: the scene run with the calibrated beams (radius ratio r, modulus E [Pa],
/// strength [Pa]) up to the first break in stage spec.check_break; that break should come at the
/// macroscopic stress sigma_t.
json run_check_break(const json& scene, const fs::path& scene_dir, const CalibrationSpec& spec, const Registry& reg,
                     const CalibrationOptions& opt, double r, double E, double strength) {
  using clock = std::chrono::steady_clock;
  json run = scene;
  run["bonds"]["params"]["radius_ratio"] = r;
  run["bonds"]["params"]["young_modulus"] = E;
  run["bonds"]["params"]["strength"] = strength;
  json stages = json::array();
  for (const auto& st : run["stages"]) {
    stages.push_back(st);
    if (st.is_object() && st.value("name", "") == spec.check_break) {
      stages.back()["until"] = {{"bonds_broken", {{"above", 0.5}}}};
      break;
    }
  }
  if (stages.size() == run["stages"].size() && !(stages.back().is_object() && stages.back().value("name", "") == spec.check_break))
    throw ConfigError("/check_break", "expected a stage of '" + spec.scenario.string() + "', found no stage '" + spec.check_break + "'");
  run["stages"] = stages;
  const auto t0 = clock::now();
  const json summary = run_scene(run, scene_dir, reg, opt.outdir / "check_break", opt.threads);
  const json* st = stage_entry(summary, spec.check_break);
  json chk = {
      {"stage", spec.check_break}, {"output", "check_break"}, {"wall_time_s", std::chrono::duration<double>(clock::now() - t0).count()}};
  if (st) {
    chk["broke"] = final_value(*st, "bonds_broken") > 0.5;
    chk["stress_at_first_break_Pa"] = final_value(*st, "tension_stress");
    // During the pull the end forces differ by the sample's inertia (the pulled end leads);
    // their mean is the stress at mid-length, where the strains are measured.
    const double mean = 0.5 * (final_value(*st, "tension_force") + final_value(*st, "tension_force_fixed")) *
                        final_value(*st, "tension_stress") / final_value(*st, "tension_force");
    chk["mean_end_stress_at_first_break_Pa"] = mean;
    chk["relative_to_tensile_strength"] = mean / spec.target_tensile_strength;
    chk["axial_strain_at_first_break"] = final_value(*st, "tension_axial_strain");
  }
  return chk;
}

}  // namespace

json calibrate_beams(const CalibrationSpec& spec, const Registry& reg, const CalibrationOptions& opt) {
  using clock = std::chrono::steady_clock;
  const auto t_start = clock::now();
  json scene = read_json_file(spec.scenario);
  const fs::path scene_dir = spec.scenario.has_parent_path() ? spec.scenario.parent_path() : fs::path(".");
  check_calibration_scene(scene, spec);
  // Parameters as the scene resolves them (failure, poisson_ratio defaults filled in).
  const json resolved_bonds = load_scenario(scene, reg, scene_dir).resolved["bonds"]["params"];
  const std::string failure = resolved_bonds["failure"].get<std::string>();
  const double beam_poisson = resolved_bonds["poisson_ratio"].get<double>();

  json report;
  report["scenario"] = spec.scenario.string();
  report["stage"] = spec.stage;
  report["targets"] = {{"young_modulus_Pa", spec.target_young_modulus},
                       {"poisson_ratio", spec.target_poisson_ratio},
                       {"tensile_strength_Pa", spec.target_tensile_strength}};
  report["tolerance"] = spec.tolerance;
  report["failure"] = failure;
  report["iterations"] = json::array();
  std::vector<double> rs, f_nu, gs;  // radius ratios, nu_M - target, E_M / E_mu
  double r = spec.initial_radius_ratio, E = spec.initial_young_modulus;
  bool converged = false;
  double stress = 0.0, crit = 0.0, E_M = 0.0, nu_M = 0.0;
  for (int k = 0; k < spec.max_iterations; ++k) {
    json run = scene;
    run["bonds"]["params"]["radius_ratio"] = r;
    run["bonds"]["params"]["young_modulus"] = E;
    run["bonds"]["params"]["strength"] = kUnbreakable;
    const auto t0 = clock::now();
    const json summary = run_scene(run, scene_dir, reg, opt.outdir / ("iter_" + std::to_string(k)), opt.threads);
    const double wall = std::chrono::duration<double>(clock::now() - t0).count();
    const json* st = stage_entry(summary, spec.stage);
    if (!st) throw SetupError("calibrate: the run has no stage '" + spec.stage + "'");
    E_M = final_value(*st, "tension_young_modulus");
    nu_M = final_value(*st, "tension_poisson_ratio");
    stress = final_value(*st, "tension_stress");
    crit = final_value(*st, "bonds_max_failure_stress");
    if (!std::isfinite(E_M) || !std::isfinite(nu_M) || !std::isfinite(stress) || !std::isfinite(crit) || !(E_M > 0.0) || !(stress > 0.0))
      throw SetupError("calibrate: stage '" + spec.stage + "' of iteration " + std::to_string(k) +
                       " gives no usable tension_test values (final tension_young_modulus " + format_number(E_M) +
                       " Pa, tension_poisson_ratio " + format_number(nu_M) + ", tension_stress " + format_number(stress) +
                       " Pa, bonds_max_failure_stress " + format_number(crit) +
                       " Pa): does the stage list the tension_test module and pull the sample in tension?");
    const double eE = E_M / spec.target_young_modulus - 1.0, enu = nu_M / spec.target_poisson_ratio - 1.0;
    json it = {{"iteration", k},
               {"radius_ratio", r},
               {"young_modulus_Pa", E},
               {"measured_young_modulus_Pa", E_M},
               {"measured_poisson_ratio", nu_M},
               {"tension_stress_Pa", stress},
               {"axial_strain", final_value(*st, "tension_axial_strain")},
               {"max_failure_stress_Pa", crit},
               {"kinetic_energy_J", final_value(*st, "kinetic_energy")},
               {"bonds_elastic_energy_J", final_value(*st, "bonds_elastic_energy")},
               {"error_young_modulus", eE},
               {"error_poisson_ratio", enu},
               {"wall_time_s", wall},
               {"output", "iter_" + std::to_string(k)}};
    report["iterations"].push_back(it);
    if (opt.on_iteration) opt.on_iteration(it);
    if (std::abs(eE) < spec.tolerance && std::abs(enu) < spec.tolerance) {
      converged = true;
      break;
    }
    rs.push_back(r);
    f_nu.push_back(nu_M - spec.target_poisson_ratio);
    gs.push_back(E_M / E);
    const double r_next = next_radius_ratio(rs, f_nu);
    E = next_young_modulus(rs, gs, r_next, spec.target_young_modulus);
    r = r_next;
  }
  report["converged"] = converged;
  report["iteration_count"] = report["iterations"].size();
  if (!converged) {
    report["wall_time_s"] = std::chrono::duration<double>(clock::now() - t_start).count();
    write_json_atomic(opt.outdir / "calibration.json", report);
    throw SetupError("calibrate: no convergence within " + std::to_string(spec.max_iterations) + " iterations (last: E_M = " +
                     format_number(E_M) + " Pa, nu_M = " + format_number(nu_M) + "); see " + (opt.outdir / "calibration.json").string());
  }
  const double strength = spec.target_tensile_strength * crit / stress;
  const json params = {
      {"young_modulus", E}, {"poisson_ratio", beam_poisson}, {"radius_ratio", r}, {"failure", failure}, {"strength", strength}};
  report["result"] = {{"params", params},
                      {"measured_young_modulus_Pa", E_M},
                      {"measured_poisson_ratio", nu_M},
                      {"criterion_to_macro_stress_ratio", crit / stress},
                      {"params_file", spec.write.string()}};
  if (!spec.check_break.empty()) report["check_break"] = run_check_break(scene, scene_dir, spec, reg, opt, r, E, strength);
  report["wall_time_s"] = std::chrono::duration<double>(clock::now() - t_start).count();
  fs::create_directories(spec.write.parent_path().empty() ? fs::path(".") : spec.write.parent_path());
  write_json_atomic(spec.write, params);
  write_json_atomic(opt.outdir / "calibration.json", report);
  return report;
}

}  // namespace sparkdem::io
