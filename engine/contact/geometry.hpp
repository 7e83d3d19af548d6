#pragma once
/// Geometry and relative motion of one contact, as seen by a contact law.
/// Convention: n is the unit normal pointing from partner j (or the wall) towards particle i;
/// the law returns the force on i (j receives the opposite).
#include <limits>

#include "engine/core/types.hpp"

namespace sparkdem {

struct ContactGeometry {
  Vec3 n;                ///< unit normal, j -> i
  double overlap = 0.0;  ///< delta = r_i + r_j - d > 0 in contact [m]
  double r_eff = 0.0;    ///< R* = r_i r_j / (r_i + r_j); r_i for a wall [m]
  double m_eff = 0.0;    ///< m* = m_i m_j / (m_i + m_j); m_i for a wall [kg]
  double arm_i = 0.0;    ///< centre of i to contact point [m]
  double arm_j = 0.0;    ///< centre of j to contact point (0 for a wall) [m]
  bool wall = false;     ///< true for a particle-wall contact
  double r_i = 0.0;      ///< radius of i [m]
  double r_j = 0.0;      ///< radius of j [m] (+inf for a wall)
  /// Filled only for laws that declare kThermal (ContactModelT): mean temperature of the pair
  /// (the particle's for a wall) from the particle field "temperature" [K], NaN without it; and
  /// the stage's time scale (physical seconds per mechanical second) for laws whose viscous
  /// processes run in physical time.
  double temperature = 0.0;
  double time_scale = 1.0;
  /// Filled only for laws that ask for it (grain_boundary_fraction_column() >= 0): the larger
  /// grain-boundary fraction f = sum_k a_k^2 / (4 r^2) of the pair's two particles over their
  /// necks a_k of the previous step (seed 000 Eq. 22: the share of a particle's surface that is
  /// grain boundary; f -> 1 as the particle's surface is all boundary, i.e. at full density).
  double gb_fraction = 0.0;
};

struct RelativeMotion {
  Vec3 v;           ///< velocity of i's contact point relative to j's [m/s]
  double vn = 0.0;  ///< v . n (< 0 when approaching) [m/s]
  Vec3 vt;          ///< tangential part v - vn n [m/s]
};

struct ContactForces {
  Vec3 force = Vec3::Zero();       ///< total force on i [N]
  Vec3 tangential = Vec3::Zero();  ///< tangential part (for torques) [N]
};

/// A contact's forces at the end of a step of dt as affine functions of its relative motion over
/// the step (the inertia-free step, engine/integrate/quasi_static.hpp): the normal force on i
/// F_n = f0 + c v (v the approach rate of the centres, -v_rel . n; known rates such as the radii's
/// thermal growth or a prescribed wall's motion already in f0), the tangential force on i
/// F_t = ft0 - ct v_t, capped at mu F_n when mu is finite, and, when `unilateral`, F_n >= 0.
/// A law that provides linear_contact(g, dt, state) -> LinearContact (state read, not written)
/// runs in quasi-static stages; the pass that follows the solve must reproduce these forces.
struct LinearContact {
  double f0 = 0.0;                                           ///< [N] normal force at zero approach rate (repulsive > 0)
  double c = 0.0;                                            ///< [N s/m] dF_n / d(approach rate)
  Vec3 ft0 = Vec3::Zero();                                   ///< [N] tangential force at zero sliding
  double ct = 0.0;                                           ///< [N s/m] -dF_t / d v_t
  double mu = std::numeric_limits<double>::infinity();       ///< Coulomb cap of |F_t| / F_n (inf: none)
  bool unilateral = false;                                   ///< compression only (a wall, a contact without a neck)
  /// [m] the viscous flow of the contact over the step (its dashpot's displacement, the part of the
  /// approach that is not elastic), affine in the approach rate: du = flow0 + flow1 v. Zero for an
  /// elastic contact. The step's length is set from it (max_strain_increment): an elastic
  /// re-balancing is instantaneous whatever the step, a creep increment is not.
  double flow0 = 0.0;
  double flow1 = 0.0;  ///< [s]
  /// An elastic Hertz normal force F_n = hertz max(overlap + v dt, 0)^(3/2) [N/m^1.5] (0: not one):
  /// the solve iterates its secant over the step instead of {f0, c}, the tangent at the start
  /// (which vanishes at zero overlap: a contact loaded from touching overshot by 0.06 of its radius).
  double hertz = 0.0;
  double overlap = 0.0;  ///< [m] at the step start (hertz > 0)
  /// [N m s] resistance of a pair's neck to the relative rotation rate W = w_i - w_j over the step:
  /// the moment on i is -(bend (I - n n^T) + twist n n^T) W (on j the opposite). Used by the
  /// quasi-static solve only (the explicit path has no contact moments; its inertia bounds the modes
  /// these remove: a particle hanging by one neck rolls about it freely).
  double bend = 0.0;
  double twist = 0.0;
};

[[gnu::always_inline]] inline RelativeMotion relative_motion(const ContactGeometry& g, const Vec3& vi, const Vec3& vj, const Vec3& wi,
                                                             const Vec3& wj) {
  RelativeMotion m;
  // The moment arm sum evaluated into a vector first: Eigen's cross of the expression itself was an
  // out-of-line call (5 % of a pour's samples); the same products and sums, so the same bits.
  const Vec3 w_arm = g.arm_i * wi + g.arm_j * wj;
  m.v = vi - vj - w_arm.cross(g.n);
  m.vn = m.v.dot(g.n);
  m.vt = m.v - m.vn * g.n;
  return m;
}

}  // namespace sparkdem
