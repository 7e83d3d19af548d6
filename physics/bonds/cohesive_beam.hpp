#pragma once
/// # cohesive_beam — GranOO's cohesive Euler–Bernoulli beam between two element centres
///
/// Source: André, Iordanoff, Charles, Néauport, CMAME 213–216 (2012) 113–125, as rebuilt in
/// ../shared/physics/cohesive-joule-torsion.md §9 (the coefficients below are the standard
/// co-rotational Euler–Bernoulli element, checked term by term by tests/component/test_cohesive_beam.cpp).
///
/// Beam: cylinder of radius r_mu = radius_ratio * (r_i + r_j)/2, length L0 = centre distance at
/// bonding, Young's modulus E, Poisson ratio nu, G = E / (2 (1 + nu)),
///   S = pi r_mu^2,  I = pi r_mu^4 / 4,  I0 = pi r_mu^4 / 2.
/// Co-rotational frame: e = unit vector i -> j (current chord), L = current length.
///   end rotations relative to the chord (vectors normal to e), from the particles' quaternions:
///     theta_i = angle(e, t_i) unit(e x t_i),  t_i = q_i * (axis i->j at bonding, body frame of i)
///     theta_j = angle(e, t_j) unit(e x t_j),  t_j = -(q_j * (axis j->i at bonding, body frame of j))
///   twist of j relative to i about e: phi = atan2(e . (a x b), a . b), with a, b the projections
///     normal to e of one reference normal vector carried by i and by j.
/// Loads on the particles (restoring; "on j" with i getting the opposite force):
///   axial    F_j = -(E S / L0) (L - L0) e
///   bending  M_i = -(2 E I / L0) (2 theta_i + theta_j),  M_j = -(2 E I / L0) (theta_i + 2 theta_j)
///   shear    F_j = e x (M_i + M_j) / L      (moment balance of the beam: d x F_j + M_i + M_j = 0)
///   torsion  M_j = -(G I0 / L0) phi e,  M_i = +(G I0 / L0) phi e
/// Elastic energy: (E S / L0)(L - L0)^2 / 2 + (2 E I / L0)(|theta_i|^2 + theta_i.theta_j + |theta_j|^2)
///                 + (G I0 / L0) phi^2 / 2.
/// Forces, moments and energy are invariant under a rigid motion of the pair, and the pair's
/// total force and total moment (about any point) are zero: action = reaction.
///
/// Failure (`failure`), from the section stresses at the two ends:
///   sigma_a = E (L - L0) / L0,  sigma_b = (2 E r_mu / L0) max_k |2 theta_k + theta_k'|,
///   tau = G r_mu |phi| / L0
///   max_normal  sigma_a + sigma_b >= strength        (André 2012: maximum tensile normal stress)
///   von_mises   sqrt((|sigma_a| + sigma_b)^2 + 3 tau^2) >= strength   (shear-dominated loading)
///   tresca      sqrt((|sigma_a| + sigma_b)^2 + 4 tau^2) >= strength
///   none        never breaks
/// (Choice, documented: the equivalent stresses take the largest normal stress of the section,
/// |sigma_a| + sigma_b, together with the largest torsional shear, which sit at the same outer
/// fibre for the torsion-dominated loading these variants are for.) The mode logged with a
/// break is the largest of the three contributions sigma_a^2, sigma_b^2, k tau^2 (k = 3 or 4;
/// 1 for max_normal): 1 axial, 2 bending, 3 torsion.
///
/// No damping term: quasi-static runs add the `local_damping` or `viscous_damping` module.
///
/// | parameter     | unit | meaning                                               |
/// |---------------|------|-------------------------------------------------------|
/// | young_modulus | Pa   | E_mu of the beam material                             |
/// | poisson_ratio | 1    | nu_mu (torsion stiffness only; André: little effect)  |
/// | radius_ratio  | 1    | r_mu / mean radius of the two particles               |
/// | failure       | —    | none, max_normal, von_mises, tresca                   |
/// | strength      | Pa   | sigma_mu_f, the criterion's threshold                 |
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/core/numbers.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem::physics {

/// Section and stiffness of one beam.
struct BeamSection {
  double r = 0.0, area = 0.0, inertia = 0.0, polar = 0.0;  ///< r_mu [m], S [m^2], I, I0 [m^4]
};

/// Kinematics of a beam in its co-rotational frame.
struct BeamKinematics {
  Vec3 e;                 ///< unit chord i -> j
  double length = 0.0;    ///< current chord length L [m]
  double stretch = 0.0;   ///< L - L0 [m]
  Vec3 theta_i, theta_j;  ///< end rotations relative to the chord [rad] (normal to e)
  double twist = 0.0;     ///< phi, rotation of j relative to i about e [rad]
};

namespace beam {

/// Rotation vector taking unit vector a onto unit vector b (angle atan2(|a x b|, a.b)).
inline Vec3 rotation_between(const Vec3& a, const Vec3& b) {
  const Vec3 c = a.cross(b);
  const double s = c.norm();
  if (s == 0.0) return Vec3::Zero();
  return std::atan2(s, a.dot(b)) / s * c;
}

inline BeamSection section(double radius_ratio, double r_i, double r_j) {
  BeamSection s;
  s.r = radius_ratio * 0.5 * (r_i + r_j);
  const double r2 = s.r * s.r;
  s.area = kPi * r2;
  s.inertia = kPi * r2 * r2 / 4.0;
  s.polar = kPi * r2 * r2 / 2.0;
  return s;
}

/// Co-rotational kinematics from the bond geometry (BondGeometry.n points j -> i).
inline BeamKinematics kinematics(const BondGeometry& g) {
  BeamKinematics k;
  k.e = -g.n;
  k.length = g.distance;
  k.stretch = g.distance - g.length0;
  k.theta_i = rotation_between(k.e, g.dir_i.normalized());
  k.theta_j = rotation_between(k.e, Vec3(-g.dir_j.normalized()));
  const Vec3 a = g.perp_i - g.perp_i.dot(k.e) * k.e;
  const Vec3 b = g.perp_j - g.perp_j.dot(k.e) * k.e;
  k.twist = std::atan2(k.e.dot(a.cross(b)), a.dot(b));
  return k;
}

}  // namespace beam

struct CohesiveBeam {
  static constexpr std::string_view kName = "cohesive_beam";
  struct Params {
    double young_modulus = 0.0;
    double poisson_ratio = 0.3;
    double radius_ratio = 0.5;
    std::string failure = "none";
    double strength = std::numeric_limits<double>::infinity();
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(std::string(kName), "bond_law",
                        "GranOO cohesive Euler-Bernoulli beam (axial, shear, bending, torsion) with brittle failure");
    s.add("young_modulus", &Params::young_modulus).unit("Pa").positive().required().doc("Young's modulus E_mu of the beam");
    s.add("poisson_ratio", &Params::poisson_ratio).unit("1").range(-0.99, 0.5).doc("Poisson ratio nu_mu (G_mu = E_mu / (2 (1 + nu_mu)))");
    s.add("radius_ratio", &Params::radius_ratio).unit("1").positive().doc("beam radius / mean radius of the two particles");
    s.add("failure", &Params::failure)
        .choices({"none", "max_normal", "von_mises", "tresca"})
        .doc("failure criterion: none, max_normal (axial + bending, André 2012), von_mises or tresca (with torsional shear)");
    s.add("strength", &Params::strength).unit("Pa").positive().doc("threshold sigma_mu_f of the failure criterion");
    return s;
  }
  static std::vector<std::string> state_columns() { return {}; }
  static std::vector<std::string> failure_modes() { return {"axial", "bending", "torsion"}; }

  explicit CohesiveBeam(const Params& p) : p_(p), shear_modulus_(p.young_modulus / (2.0 * (1.0 + p.poisson_ratio))) {
    kind_ = p.failure == "max_normal" ? 1 : p.failure == "von_mises" ? 2 : p.failure == "tresca" ? 3 : 0;
  }

  /// Section stresses (sigma_a, sigma_b, tau) [Pa] of a beam.
  struct Stresses {
    double axial = 0.0, bending = 0.0, shear = 0.0;
  };
  Stresses stresses(const BondGeometry& g, const BeamKinematics& k) const {
    const BeamSection sec = beam::section(p_.radius_ratio, g.r_i, g.r_j);
    Stresses st;
    st.axial = p_.young_modulus * k.stretch / g.length0;
    const double bi = (2.0 * k.theta_i + k.theta_j).norm(), bj = (k.theta_i + 2.0 * k.theta_j).norm();
    st.bending = 2.0 * p_.young_modulus * sec.r / g.length0 * std::max(bi, bj);
    st.shear = shear_modulus_ * sec.r * std::abs(k.twist) / g.length0;
    return st;
  }
  /// The failure criterion's stress [Pa] (0 with failure = none).
  double criterion(const Stresses& st) const {
    const double n = std::abs(st.axial) + st.bending;
    switch (kind_) {
      case 1:
        return st.axial + st.bending;
      case 2:
        return std::sqrt(n * n + 3.0 * st.shear * st.shear);
      case 3:
        return std::sqrt(n * n + 4.0 * st.shear * st.shear);
      default:
        return 0.0;
    }
  }
  double failure_stress(const BondGeometry& g, const double*) const { return criterion(stresses(g, beam::kinematics(g))); }

  BondForces operator()(const BondGeometry& g, const BondMotion&, double, double*) const {
    const BeamKinematics k = beam::kinematics(g);
    const BeamSection sec = beam::section(p_.radius_ratio, g.r_i, g.r_j);
    const double E = p_.young_modulus, L0 = g.length0;
    const double ka = E * sec.area / L0, kb = 2.0 * E * sec.inertia / L0, kt = shear_modulus_ * sec.polar / L0;
    const Vec3 Mi = -kb * (2.0 * k.theta_i + k.theta_j);
    const Vec3 Mj = -kb * (k.theta_i + 2.0 * k.theta_j);
    const Vec3 Fj = -ka * k.stretch * k.e + k.e.cross(Mi + Mj) / k.length;
    BondForces f;
    f.force = -Fj;
    f.torque_i = Mi + kt * k.twist * k.e;
    f.torque_j = Mj - kt * k.twist * k.e;
    if (kind_ != 0) {
      const Stresses st = stresses(g, k);
      if (criterion(st) >= p_.strength) {
        f.broken = true;
        const double w = kind_ == 3 ? 4.0 : kind_ == 2 ? 3.0 : 1.0;
        const double a = st.axial * st.axial, b = st.bending * st.bending, t = kind_ == 1 ? 0.0 : w * st.shear * st.shear;
        f.mode = a >= b && a >= t ? 1 : b >= t ? 2 : 3;
      }
    }
    return f;
  }

  double energy(const BondGeometry& g, const double*) const {
    const BeamKinematics k = beam::kinematics(g);
    const BeamSection sec = beam::section(p_.radius_ratio, g.r_i, g.r_j);
    const double E = p_.young_modulus, L0 = g.length0;
    return 0.5 * E * sec.area / L0 * k.stretch * k.stretch +
           2.0 * E * sec.inertia / L0 * (k.theta_i.squaredNorm() + k.theta_i.dot(k.theta_j) + k.theta_j.squaredNorm()) +
           0.5 * shear_modulus_ * sec.polar / L0 * k.twist * k.twist;
  }

  /// Stiffnesses for the stable step: axial E S / L0, shear 12 E I / L0^3, bending 4 E I / L0
  /// (the end's own rotational stiffness), torsion G I0 / L0.
  BondStiffness stiffness(const BondGeometry& g) const {
    const BeamSection sec = beam::section(p_.radius_ratio, g.r_i, g.r_j);
    const double E = p_.young_modulus, L0 = g.length0;
    return {E * sec.area / L0, 12.0 * E * sec.inertia / (L0 * L0 * L0), 4.0 * E * sec.inertia / L0, shear_modulus_ * sec.polar / L0};
  }

  const Params& params() const { return p_; }

 private:
  Params p_;
  double shear_modulus_;
  int kind_ = 0;
};

}  // namespace sparkdem::physics
