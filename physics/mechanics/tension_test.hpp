#pragma once
/// # tension_test — macroscopic stress, strains, Young's modulus and Poisson ratio of a
/// cylindrical sample pulled along its axis (the measurement of the beam calibration,
/// ../shared/physics/cohesive-joule-torsion.md §9.3; io/scenario/calibrate_beams.hpp)
///
/// Set-up: a cylinder of radius R whose axis passes through `axis_point` along the unit vector
/// a = `axis`/|`axis`|; the particle set `fixed` is clamped at one end and the set `pulled` is
/// moved along a at the other (stage key `prescribe`).
///
/// Reference configuration: each particle's position x0 is captured once, when the module first
/// binds (the start of the first stage that lists it), into the particle field "tension/x0"
/// [m] (3 components, initialised to NaN = not captured; checkpointed, permuted with the
/// particles and carried to later stages, so a later stage or a restart never recaptures).
/// Particles added later are captured at the next binding or call. Displacement u = x - x0.
///
/// Axial and radial reference coordinates of particle i:
///   s_i = (x0_i - p) . a,   q_i = (x0_i - p) - s_i a,   rho_i = |q_i|,   n_i = q_i / rho_i.
/// Measured region ("middle"): the particles with |s_i - s_c| <= f (s_max - s_min) / 2, where
/// s_min, s_max are the extreme reference centres of the whole sample, s_c their midpoint and
/// f = `middle_fraction`: the central part of the length, away from the clamped ends where the
/// sets' rigid motion constrains the lateral contraction (Saint-Venant).
/// Strains (small-strain, displacement based), least squares over the middle particles:
///   axial    u_i . a = eps_a s_i + c      (with intercept: the rigid axial translation is free)
///            eps_a = sum (s_i - s̄)(w_i - w̄) / sum (s_i - s̄)^2,  w_i = u_i . a
///   lateral  u_i . n_i = eps_l rho_i      (through the origin: a uniform lateral strain of a
///            body of revolution has no radial offset on the axis)
///            eps_l = sum rho_i (u_i . n_i) / sum rho_i^2
///   Particles with rho_i <= 1e-9 R (direction n_i undefined) are left out of the lateral fit;
///   the rho^2 weighting makes the ones close to the axis count little anyway.
/// Both fits return exactly the strains of an affine deformation x = p + F (x0 - p) with
/// F = eps_a a a^T + eps_l (I - a a^T) (+ identity): tests/component/test_tension_test.cpp.
/// Forces: F_set = sum over the set's members of the particle force (after the step: the
/// reaction of the sample on a prescribed set; local_damping leaves prescribed particles alone).
/// With d = sign((centroid of pulled - centroid of fixed) . a), the sample pulls the pulled set
/// back along -d a and the fixed set along +d a, so in tension
///   tension_force        = -d F_pulled . a   [N]   (> 0 in tension)
///   tension_force_fixed  = +d F_fixed . a    [N]   (equal to the above when quasi-static)
///   tension_stress       = tension_force / (pi R^2)   [Pa]  (nominal: reference section)
///   tension_young_modulus = tension_stress / eps_a      [Pa]
///   tension_poisson_ratio = -eps_l / eps_a              [1]
/// (E and nu are NaN while eps_a = 0, e.g. before the first step.)
///
/// The values are computed from the state when the time series is sampled (nothing is kept
/// between calls but the reference field), so the module's clock does not matter; its call
/// only captures references of particles that have none.
///
/// | parameter       | unit | meaning                                                          |
/// |-----------------|------|------------------------------------------------------------------|
/// | axis_point      | m    | a point p of the sample's axis                                   |
/// | axis            | 1    | axis direction (any non-zero length; default z)                  |
/// | radius          | m    | R, sample radius for the stress area pi R^2                      |
/// | pulled          | —    | particle set moved along the axis (listed in the stage's `sets`) |
/// | fixed           | —    | particle set clamped at the other end                            |
/// | middle_fraction | 1    | f, central fraction of the length where the strains are measured |
///
/// Columns: tension_force, tension_force_fixed [N], tension_stress [Pa], tension_axial_strain,
/// tension_lateral_strain [1], tension_young_modulus [Pa], tension_poisson_ratio [1],
/// tension_middle_count (particles in the measured region).
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

class TensionTest final : public Module {
 public:
  struct Params {
    Vec3 axis_point = Vec3::Zero();
    Vec3 axis = Vec3::UnitZ();
    double radius = 0.0;  ///< [m]
    std::string pulled;
    std::string fixed;
    double middle_fraction = 0.5;  ///< [1]
  };
  static ParamSpec<Params> spec();
  /// Throws ConfigError (paths relative to the module) for a zero axis.
  explicit TensionTest(const Params& p);
  std::string name() const override { return "tension_test"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  void advance(State& s, const StepInfo& step) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;

  /// The measured figures (see the header comment).
  struct Result {
    double force = 0.0, force_fixed = 0.0, stress = 0.0;
    double axial_strain = 0.0, lateral_strain = 0.0;
    double young_modulus = 0.0, poisson_ratio = 0.0;
    std::size_t middle = 0;
  };
  Result measure(const State& s) const;

  static constexpr const char* kReferenceField = "tension/x0";

 private:
  static void capture(State& s);
  Params p_;
  Vec3 a_;  ///< unit axis
};

}  // namespace sparkdem::physics
