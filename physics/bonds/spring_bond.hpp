#pragma once
/// # spring_bond — a breakable elastic spring between two particles
///
/// The simplest bond law, a translational spring pair as in lattice-spring and bonded-particle
/// models without moment transfer (Potyondy & Cundall 2004's parallel bond with the moment
/// terms left out). The contact point sits halfway along the current centre line.
///
///   axial:    F_n = -k_n (d - L0) n                 (n = unit vector j -> i, L0 = length at bonding)
///   shear:    s <- s_rotated + v_t dt,  F_t = -k_t s (incremental shear displacement, no slip;
///                                                       kernel::tangential_history with no limit)
///   torques:  T_i = -(d/2) n x F_t,  T_j = -(d/2) n x F_t
///   failure:  (d - L0) / L0 > tensile_strain  or  |F_t| > shear_force_limit  -> broken
///
/// No damping term: add the `viscous_damping` module or a damped contact law. Bending and
/// torsion carry no moment (a chain of spring bonds is a mechanism in bending).
/// State columns shear_x/y/z carry over to and from contact laws with the same history names
/// (hertz_mindlin, linear_spring_dashpot) when a contact becomes a bond or a bond breaks.
///
/// | parameter          | unit | meaning                                    |
/// |--------------------|------|--------------------------------------------|
/// | normal_stiffness   | N/m  | k_n                                        |
/// | shear_stiffness    | N/m  | k_t                                        |
/// | tensile_strain     | 1    | axial strain at failure (inf: unbreakable) |
/// | shear_force_limit  | N    | shear force at failure (inf: unbreakable)  |
#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/contact/contact_kernels.hpp"

namespace sparkdem::physics {

struct SpringBond {
  static constexpr std::string_view kName = "spring_bond";
  struct Params {
    double normal_stiffness = 1e4;
    double shear_stiffness = 0.0;
    double tensile_strain = std::numeric_limits<double>::infinity();
    double shear_force_limit = std::numeric_limits<double>::infinity();
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(std::string(kName), "bond_law", "breakable axial + shear spring between two particles (no moments)");
    s.add("normal_stiffness", &Params::normal_stiffness).unit("N/m").positive().doc("axial stiffness k_n");
    s.add("shear_stiffness", &Params::shear_stiffness).unit("N/m").nonnegative().doc("shear stiffness k_t");
    s.add("tensile_strain", &Params::tensile_strain).unit("1").positive().doc("axial strain (d - L0)/L0 at failure");
    s.add("shear_force_limit", &Params::shear_force_limit).unit("N").positive().doc("shear force at failure");
    return s;
  }
  static std::vector<std::string> state_columns() { return {"shear_x", "shear_y", "shear_z"}; }

  explicit SpringBond(const Params& p) : p_(p) {}

  BondForces operator()(const BondGeometry& g, const BondMotion& m, double dt, double* s) const {
    const double half = 0.5 * g.distance;
    const Vec3 v = m.v_ij - (half * m.omega_i + half * m.omega_j).cross(g.n);
    const Vec3 vt = v - v.dot(g.n) * g.n;
    BondForces f;
    const double stretch = g.distance - g.length0;
    const Vec3 ft = kernel::tangential_history(g.n, vt, p_.shear_stiffness, 0.0, 1.0, std::numeric_limits<double>::infinity(), dt, s);
    f.force = -p_.normal_stiffness * stretch * g.n + ft;
    f.torque_i = -half * g.n.cross(ft);
    f.torque_j = f.torque_i;
    const bool axial = stretch > p_.tensile_strain * g.length0;
    f.broken = axial || ft.norm() > p_.shear_force_limit;
    f.mode = f.broken ? (axial ? 1 : 2) : 0;
    return f;
  }
  static std::vector<std::string> failure_modes() { return {"axial", "shear"}; }
  /// Elastic energy k_n (d - L0)^2 / 2 + k_t |s|^2 / 2 [J].
  double energy(const BondGeometry& g, const double* s) const {
    const double stretch = g.distance - g.length0;
    return 0.5 * p_.normal_stiffness * stretch * stretch + 0.5 * p_.shear_stiffness * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  }
  BondStiffness stiffness(const BondGeometry&) const { return {p_.normal_stiffness, p_.shear_stiffness, 0.0, 0.0}; }

 private:
  Params p_;
};

}  // namespace sparkdem::physics
