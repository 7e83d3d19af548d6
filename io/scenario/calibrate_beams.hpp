#pragma once
/// `sparkdem calibrate`: the cohesive-beam calibration (../shared/physics/cohesive-joule-torsion.md
/// §9.3; André et al., CMAME 213–216 (2012) 113–125, §4): finds the beam parameters of the
/// `cohesive_beam` bond law that give a bonded packing a target macroscopic Young's modulus E_M,
/// Poisson ratio nu_M and tensile strength sigma_t, from a quasi-static tension test measured by
/// the `tension_test` module (physics/mechanics/tension_test.hpp).
///
/// Calibration file (paths relative to it):
///   {"scenario": "tension scene", "stage": "stage whose final values are read",
///    "targets": {"young_modulus": Pa, "poisson_ratio": 1, "tensile_strength": Pa},
///    "initial": {"radius_ratio": 1, "young_modulus": Pa},
///    "tolerance": 0.01, "max_iterations": 12, "write": "params file to write",
///    "check_break": "loading stage"}   (optional)
///
/// Facts used (all beam stiffnesses are proportional to E_mu; the packing is fixed):
///   nu_M = nu_M(r~) depends on the radius ratio r~ only; E_M = E_mu g(r~) is linear in E_mu.
/// Loop, iteration k (run of the scene with /bonds/params/{radius_ratio, young_modulus} = r_k,
/// E_k and strength = 1e30, so the criterion stress is measured but nothing breaks):
///   relative errors  e_E = E_M / E_target - 1,  e_nu = nu_M / nu_target - 1; stop when both
///                    |e| < tolerance
///   E_{k+1} = E_target / g(r_{k+1})  with g(r~) = E_M / E_mu (linearity in E_mu) measured at
///            the iterations and extrapolated as a power law g ~ r~^p from the last one (p from
///            the last two, 2 at the first step: axial stiffness ~ r_mu^2); for an unchanged r~
///            this is the plain rescaling E_{k+1} = E_k E_target / E_M
///   r_{k+1}: secant on f(r) = nu_M(r) - nu_target through the last two iterations; the first
///            step (one point only) assumes the usual decrease of nu_M with r~ (stiffer bending
///            resists the non-affine rotations that make the lateral contraction):
///            r_1 = r_0 (1 + 0.25 sign(f_0)). Every new r is kept within [r_k / 2, 2 r_k] and,
///            once points on both sides of the target are known, inside the tightest such
///            bracket (regula falsi on its ends, then bisection, when the secant leaves it).
/// Strength: the run is linear-elastic (no break), so the largest criterion stress over the
///   bonds scales with the macroscopic stress; the first bond breaks at macroscopic stress
///   sigma_t when
///     sigma_mu_f = sigma_t * bonds_max_failure_stress / tension_stress      (converged run).
/// Outputs: OUTDIR/iter_K/ (the runs), OUTDIR/calibration.json (every iteration: parameters,
/// measured E_M, nu_M, stress, criterion stress, errors, wall time; the result), the params file
/// `write` = {young_modulus, poisson_ratio, radius_ratio, failure, strength} (atomically), for
///   "bonds": {"law": "cohesive_beam", "params": {"$include": "that file"}}.
/// With check_break = name of the loading stage: one more run (OUTDIR/check_break) with the
/// calibrated strength, that stage stopped at the first break (until bonds_broken > 0.5) and the
/// stages after it left out, reporting the macroscopic stress then against sigma_t (the stage
/// must load far enough to reach sigma_t). During a pull the two end forces differ by the
/// sample's inertia (a few %), so the figure compared is their mean, the stress at mid-length:
///   sigma_break = (tension_force + tension_force_fixed) / (2 pi R^2).
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/model/registry.hpp"

namespace sparkdem::io {

struct CalibrationSpec {
  std::filesystem::path scenario;  ///< tension scene (absolute or relative to the working directory)
  std::string stage;
  double target_young_modulus = 0.0;     ///< [Pa]
  double target_poisson_ratio = 0.0;     ///< [1]
  double target_tensile_strength = 0.0;  ///< [Pa]
  double initial_radius_ratio = 0.0;     ///< [1]
  double initial_young_modulus = 0.0;    ///< [Pa]
  double tolerance = 0.01;               ///< relative
  int max_iterations = 12;
  std::filesystem::path write;  ///< params file
  std::string check_break;      ///< loading stage of the break check (empty: no check)
};

/// Validate a calibration file's JSON (every problem at once: ConfigError with JSON paths);
/// relative paths are resolved against `base_dir`.
CalibrationSpec parse_calibration(const nlohmann::json& j, const std::filesystem::path& base_dir);

struct CalibrationOptions {
  std::filesystem::path outdir = "calibration_out";
  int threads = 0;
  /// Called after every run with its record (progress display; may be empty).
  std::function<void(const nlohmann::json&)> on_iteration;
};

/// Run the calibration; returns what is written to OUTDIR/calibration.json. Throws ConfigError
/// (scene without cohesive_beam bonds and a failure criterion, missing stage), SetupError (no
/// tension_test columns, no convergence within max_iterations: calibration.json is written
/// first), PhysicsError and Interrupted from the runs.
nlohmann::json calibrate_beams(const CalibrationSpec& spec, const Registry& reg, const CalibrationOptions& opt);

}  // namespace sparkdem::io
