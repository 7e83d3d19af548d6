#pragma once
/// Sphere element: the conductance matrix of ONE spherical particle between the circular patches
/// (necks) through which current enters or leaves it. Pure functions, SI units.
///
/// WHY. The particle-centred network of seed 000 gives every neck its own half-particle
/// ("hemisphere", Eq. 19-20) joined at the centre. A particle with n necks then lends its volume
/// n/2 times over; in random sintered packings (7-10 necks per particle) the network conducts
/// more than the Hashin-Shtrikman upper bound kappa 2(1-p)/(2+p) allows (issue 21,
/// benchmarks/sps_nial/). The sphere element keeps one conductor per particle and lets all of its
/// necks share it: the nodes are the necks, the particle is a multi-terminal element.
///
/// MODEL (the discrete thermal element idea of Feng, Han, Li, Owen, J. Comput. Phys. 227 (2008)
/// 5072, there for discs in 2-D, written here for spheres; derivation own): a sphere of radius R
/// and conductivity kappa; current J_q enters through patch q, a spherical cap of half-angle
/// alpha_q about the unit direction u_q, uniformly spread over the cap (sum_q J_q = 0); the rest
/// of the surface is insulated. The interior potential is the Neumann solution in spherical
/// harmonics; its mean over cap p is V_p = sum_q H_pq J_q + const with
///
///   H_pq = 1/(4 pi kappa R) sum_{l>=1} (2l+1)/l  beta_l(alpha_p) beta_l(alpha_q) P_l(u_p . u_q),
///   beta_l(alpha) = [P_{l-1}(cos alpha) - P_{l+1}(cos alpha)] / ((2l+1)(1 - cos alpha))
///
/// (beta_l = the mean of P_l over the cap, by the Funk-Hecke theorem; P_l Legendre). The element
/// conductance matrix is the inverse of H on the zero-sum currents:
///   J = K V,  K = Q (Q^T H Q)^{-1} Q^T,  Q an orthonormal basis of {x : sum x = 0},
/// symmetric, positive semi-definite, with zero row sums (a current only flows between patches).
///
/// CHECKS (tests/unit/test_sphere_element.cpp): for a small cap, H_pp -> 8/(3 pi^2 kappa a), the
/// mean temperature of a uniformly heated disc of radius a = R sin(alpha) on a half-space
/// (Carslaw and Jaeger, Conduction of Heat in Solids, §8.2; Yovanovich's uniform-flux spreading
/// resistance), 8 % above Holm's isopotential 1/(4 kappa a): the uniform-flux patch is the
/// element's approximation, and it makes K a lower estimate of the isopotential neck.
///
/// TRUNCATION: l <= l_max = min(l_cap, max(l_min, ceil(l_per_radian / alpha_min))); beta_l decays
/// as (l alpha)^(-3/2), so the series tail after l_max is O((l_max alpha)^(-2)) of H_pp:
/// l_per_radian = 60 leaves < 0.1 % (measured in the unit test against l_per_radian = 240).
#include <span>

#include <Eigen/Dense>

#include "engine/core/types.hpp"

namespace sparkdem::physics::electrical {

struct SphereElementOptions {
  double l_per_radian = 60.0;  ///< l_max = l_per_radian / alpha_min (smallest cap half-angle) [1/rad]
  int l_min = 40;              ///< lower limit of l_max
  int l_cap = 6000;            ///< upper limit of l_max (caps below ~0.01 rad are truncated)
};

/// The patch resistance kernel H [Ohm] (n x n, symmetric) of a sphere of radius R_m and
/// conductivity kappa for caps of half-angle alpha_rad[p] in (0, pi/2] about unit directions
/// u[p]. Throws ConfigError on invalid arguments.
Eigen::MatrixXd sphere_patch_resistance(double kappa_S_per_m, double R_m, std::span<const Vec3> u, std::span<const double> alpha_rad,
                                        const SphereElementOptions& o = {});

/// The element conductance matrix K [S] (n x n): J = K V for the currents J entering through the
/// patches and the patch (mean) potentials V. n = 0 or 1 gives a zero matrix (no current can
/// flow through a particle with one neck).
Eigen::MatrixXd sphere_patch_conductance(double kappa_S_per_m, double R_m, std::span<const Vec3> u, std::span<const double> alpha_rad,
                                         const SphereElementOptions& o = {});

/// How a neck of radius a becomes a cap on the sphere of radius R:
///  - EqualArea (default): the cap has the neck's area, 2 pi R^2 (1 - cos alpha) = pi a^2, i.e.
///    alpha = 2 asin(a / 2R). With the grain-boundary-fraction correction (sum pi a^2 <= 4 pi R^2,
///    Eq. 22-25) the caps of a particle then never cover more than its surface.
///  - Rim: the cap has the neck's rim, alpha = asin(a / R) (a cap of a = R is a hemisphere; seven
///    to ten such caps cover the sphere several times over, and overlapping caps short their necks).
/// Chosen on the simple cubic lattice against the voxel continuum of the same spheres
/// (tools/voxel_conductivity.py; README "Sintered-neck networks"), not on any measured sample.
enum class CapRule { EqualArea, Rim };

/// Cap half-angle [rad] of a neck of radius a_m on a sphere of radius R_m (a <= R; larger a is
/// taken as R).
double cap_half_angle(double a_m, double R_m, CapRule rule = CapRule::EqualArea);

}  // namespace sparkdem::physics::electrical
