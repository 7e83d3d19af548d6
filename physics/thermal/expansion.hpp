#pragma once
/// Thermal expansion of the particle radii, shared by every module that writes `temperature`
/// (temperature_history: one T for all; heat_conduction: T per particle).
///   r_i = r_ref,i (1 + alpha_T (T_i - T_0))          (sintering-electrical.md §3.3)
/// evaluated as a function of T, never compounded per step. Mass is constant; the moment of
/// inertia follows the radius, I_i = 2/5 m_i r_i^2.
///
/// Reference-radius rule: fields "radius_ref" [m] and "radius_ref_temperature" [K]. A particle's
/// reference radius is captured ONCE, when a module with alpha_T != 0 first binds and the
/// particle has none yet (radius_ref = current radius, taken to be the radius at T_0). The
/// fields are checkpointed and carried to later stages, so a later stage (or a restart) never
/// recaptures from already expanded radii; a later stage must give the same T_0.
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics::thermal {

/// A particle field other modules may keep: a factor on the thermally expanded radius (the
/// mass-conserving growth of sintered particles, physics/contact/mass_conserving_radii.hpp). When
/// the field exists, apply_expansion sets r_i = r_ref,i (1 + alpha_T (T_i - T_0)) g_i.
inline constexpr const char* kRadiusFactorField = "mass_conserving_radii/factor";
/// The closed share of each grown particle's surface, sum_j h_j / (2 R) over the caps on its
/// necks' radical planes (capped at 1), and whether it reached the module's dense_closed_surface
/// (1 or 0: the particle is dense), written by the same module; the sintering law's
/// stop_flow_at_dense reads the flag.
inline constexpr const char* kClosedSurfaceField = "mass_conserving_radii/closed_surface";
inline constexpr const char* kDenseField = "mass_conserving_radii/dense";

/// Thermally expanded radius [m]: r = r_ref (1 + alpha (T - T0)).
inline double expanded_radius(double r_ref, double alpha, double T, double T0) { return r_ref * (1.0 + alpha * (T - T0)); }

/// The fields the expansion needs (declare them when alpha_T != 0), and the writes/reads.
void declare_expansion(Declarations& d);

/// Capture the reference radii of particles that have none (see the rule above). Throws
/// SetupError naming `module` when a particle's reference was captured at another T_0.
void capture_reference_radii(State& s, double t0_K, const std::string& module);

/// Set every particle's radius (and inertia) from its temperature T[i] [K] (size = particles).
void apply_expansion(State& s, double alpha_per_K, double t0_K, const std::vector<double>& T);
/// Same with one temperature for every particle.
void apply_expansion(State& s, double alpha_per_K, double t0_K, double T);

}  // namespace sparkdem::physics::thermal
