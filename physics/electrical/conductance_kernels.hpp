#pragma once
/// Branch conductance kernels of the electrical network (issue 4). Pure functions: no state, no
/// I/O, no JSON; SI units throughout (lengths [m], conductances [S], resistances [Ohm],
/// conductivities [S/m], resistivities [Ohm m], temperatures [K]). The network module turns the
/// per-edge geometry of engine/graph/interaction_graph.hpp (distance, overlap (> 0 overlap,
/// < 0 gap), radius) into one conductance per edge with these kernels.
///
/// MODELS (equation, source; the physics notes are in /work/shared/physics/):
///
///  Series combination      1/G = sum_k 1/G_k (G_k = +inf: a short; G_k = 0: an open branch).
///
///  1. Holm constriction of an unbonded contact (Holm, Electric Contacts, 1967: a circular spot of
///     radius a on a half-space has constriction resistance 1/(4 a kappa); sintering-electrical.md
///     §2.4, small-a limit K -> 4 kappa a):
///        R = 1/(4 a kappa_i) + 1/(4 a kappa_j),  G = 4 a kappa_i kappa_j/(kappa_i + kappa_j)
///          = 2 a kappa_eff, kappa_eff = 2 kappa_i kappa_j/(kappa_i + kappa_j) (= 2 a kappa for
///          equal bodies).
///     Contact radius from the caller: hertz_contact_radius a = sqrt(R* delta),
///     R* = r_i r_j/(r_i + r_j) (Hertz; Johnson, Contact Mechanics §4.2), or the geometric lens
///     radius of the graph edge (engine lens_radius, ~ sqrt(2 R* delta)).
///  2. Sintered neck (seed 000 = Nisar et al. 2024, Eqs. 17-26; sintering-electrical.md §2.4-2.7):
///        K_ij = K_i K_j K_c / (K_i K_j + K_j K_c + K_i K_c)                        (Eq. 18)
///        K_i  = kappa pi r_i (c1 a/r_i + c0)            (Eqs. 19-20, readings A/B/C of the OCR)
///             or kappa pi r_i k_FE(a/r_i)               (the note's FE table, §2.4)
///             clamped to K_i >= phi 4 kappa a (positive floor, see HemisphereLaw)
///        K_c  = eps kappa pi a^2 / delta_gb                                       (Eq. 26)
///        a    = sqrt(2 r* h),  r* = 2 r_i r_j/(r_i + r_j)                         (Eq. 21, Coble)
///        a    = constant-volume (CV) neck: lens volume moved into a cylindrical collar (§2.5)
///        alpha_i = min(1, 2 r_i / sqrt(sum_j a_ij^2)),  a_ij <- min(alpha_i, alpha_j) a_ij
///                                                      (Eqs. 22-25, grain-boundary fraction)
///  3. Transmission surface (seed 001 = Hubert et al. 2017, Eqs. 2-5; cohesive-joule-torsion.md §3):
///        e_i  = |mean_j x_j - x_i| / r_i                                (Eq. 2, rebuilt)
///        S_i  = alpha(n_i) r_i^2 / f(e_i),  f = 1 (e < 0.4), 2 (e >= 0.4)          (Eq. 3)
///        R_ij = rho_e l_ij / sqrt(S_i S_j)                                        (Eqs. 4-5)
///     with the alpha(n), f_v(n) table of the Platonic polyhedra circumscribed about the sphere
///     (Terreros reconstruction, §3.3).
///  4. Touching on/off (seed 002, cpc-and-networks.md §1.3-1.4): G = g_unit if overlap >= -tol,
///     else 0.  Tunnelling (Grimaldi/Balberg form, cpc-and-networks.md §1.3, optional extension):
///     G = g0 exp(-2 gap/xi) for gap <= cut-off, else 0.
///  5. Bulk conductivity kappa(T): linear resistivity rho = rho_ref (1 + beta (T - T_ref)), i.e.
///     kappa = kappa_ref / (1 + beta (T - T_ref)) (the usual metal law), or a table
///     piecewise linear in T, clamped at the ends.
///
/// ERRORS. Invalid arguments (negative lengths, non-positive conductivities, a temperature outside
/// a law's validity range, malformed tables) throw ConfigError with an empty path, as the other
/// pure physics functions do. A caller that knows the step and the particles concerned (the
/// network module) may catch and re-throw as PhysicsError.
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <variant>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/core/numbers.hpp"
#include "engine/core/types.hpp"

namespace sparkdem::physics::electrical {

namespace detail {
/// Throws ConfigError("", "<what> must be <expected>, found <value>").
[[noreturn]] void invalid(const char* what, const char* expected, double value);
inline void require_nonnegative(const char* what, double v) {
  if (!(v >= 0.0) || std::isinf(v)) invalid(what, ">= 0 and finite", v);
}
inline void require_positive(const char* what, double v) {
  if (!(v > 0.0) || std::isinf(v)) invalid(what, "> 0 and finite", v);
}
inline void require_positive_or_inf(const char* what, double v) {
  if (!(v > 0.0)) invalid(what, "> 0 (+inf allowed)", v);
}
}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Series combination
// ---------------------------------------------------------------------------------------------

/// Series combination of conductances [S]: G = 1 / sum_k (1/G_k).
/// Each G_k must be >= 0 (NaN rejected). G_k = +inf is a perfect conductor (drops out of the
/// sum); any G_k = 0 opens the branch (G = 0); all infinite gives +inf. Written in reciprocal
/// form so that no product K_i K_j K_c can overflow or produce inf/inf (Eq. 18 of seed 000 is
/// the three-term case).
inline double series_conductance(std::span<const double> g_S) {
  double r = 0.0;  // total resistance [Ohm]
  bool open = false;
  for (const double g : g_S) {
    if (!(g >= 0.0)) detail::invalid("conductance [S]", ">= 0 (+inf allowed)", g);
    if (g == 0.0)
      open = true;
    else if (!std::isinf(g))
      r += 1.0 / g;
  }
  if (open) return 0.0;
  return r > 0.0 ? 1.0 / r : kInf;
}
inline double series_conductance(double g1_S, double g2_S) {
  const double g[2] = {g1_S, g2_S};
  return series_conductance(std::span<const double>(g, 2));
}
inline double series_conductance(double g1_S, double g2_S, double g3_S) {
  const double g[3] = {g1_S, g2_S, g3_S};
  return series_conductance(std::span<const double>(g, 3));
}

// ---------------------------------------------------------------------------------------------
// 1. Holm constriction (unbonded contact)
// ---------------------------------------------------------------------------------------------

/// Hertz contact radius [m]: a = sqrt(R* delta), 1/R* = 1/r_i + 1/r_j (Hertz 1882; Johnson,
/// Contact Mechanics §4.2). r_j = +inf is a plane (R* = r_i). overlap <= 0 gives 0.
/// Validity: elastic, small overlap (delta << R*).
/// Which radius the caller uses is its choice: Hertz (elastic contact spot, a^2 = R* delta) or
/// the geometric lens radius carried by Contact edges of the interaction graph
/// (a^2 ~ 2 R* delta, larger by sqrt 2). The Holm kernel only takes a.
inline double hertz_contact_radius(double r_i_m, double r_j_m, double overlap_m) {
  detail::require_positive("particle radius r_i [m]", r_i_m);
  detail::require_positive_or_inf("particle radius r_j [m]", r_j_m);
  if (std::isnan(overlap_m)) detail::invalid("overlap [m]", "a number", overlap_m);
  if (!(overlap_m > 0.0)) return 0.0;
  const double r_eff = 1.0 / (1.0 / r_i_m + 1.0 / r_j_m);
  return std::sqrt(r_eff * overlap_m);
}

/// Holm constriction conductance of a circular contact spot between two bodies [S]:
///   R = 1/(4 a kappa_i) + 1/(4 a kappa_j)   (each body a half-space; Holm 1967, Maxwell 1873)
///   G = 4 a kappa_i kappa_j / (kappa_i + kappa_j)  (= 2 a kappa for equal conductivities).
/// a = 0 gives 0. kappa = +inf is a perfect conductor on that side.
/// Validity: a << r (half-space assumption; the note's FE shows ~8 % excess at a/r = 0.05 for
/// a sphere, growing with a/r); no film or oxide resistance.
inline double holm_conductance(double a_m, double kappa_i_S_per_m, double kappa_j_S_per_m) {
  detail::require_nonnegative("contact radius a [m]", a_m);
  detail::require_positive_or_inf("conductivity kappa_i [S/m]", kappa_i_S_per_m);
  detail::require_positive_or_inf("conductivity kappa_j [S/m]", kappa_j_S_per_m);
  return series_conductance(4.0 * a_m * kappa_i_S_per_m, 4.0 * a_m * kappa_j_S_per_m);
}

// ---------------------------------------------------------------------------------------------
// 2. Sintered neck (seed 000, Eqs. 17-26)
// ---------------------------------------------------------------------------------------------

/// Normalised hemisphere conductance k_FE(x) = K_i / (kappa pi r) of the note's axisymmetric FE
/// table (sintering-electrical.md §2.4), x = a/r:
///  - 0.05 <= x <= 0.99: linear interpolation of the 13 table points;
///  - 0.99 < x <= 1: linear extrapolation of the last segment; x > 1 is clamped to x = 1 (the
///    neck cannot exceed the particle; the caller caps a <= r_min, §7.9);
///  - x < 0.05: Holm constriction in series with a bulk term,
///      k = 1 / (pi/(4x) + c_b),  c_b = 1/k_FE(0.05) - pi/(4 * 0.05) = 1.2414,
///    which tends to the Holm limit K -> 4 kappa a as x -> 0 and is continuous (and monotone) at
///    0.05. (The plain Holm value 4 kappa a is 8 % above the table at 0.05, so switching to it
///    there would make K decrease with a.)
/// x = 0 gives 0. Throws ConfigError for x < 0 or NaN.
double fe_hemisphere_normalised(double a_over_r);

/// Hemisphere ("half-particle") conductance law K_i(a, r_i), seed 000 Eqs. (19)-(20).
///
/// Coefficients: Eq. (19) is garbled in the seed's text. Readings (sintering-electrical.md §2.4):
///   A (1.15, -0.08)  most probable reading; K_i < 0 below a/r = 0.07;
///   B (1.15, +0.08)  same layout without the minus; K_i > 0 at a -> 0;
///   C (1.08, +0.15)  "q08" read as 1.08; overestimates at small a;
///   fe_table         the note's own FE solution (physics, not the paper's law).
/// DEFAULT = reading A: it is the most probable reading of the seed, and the seed's calibrated
/// grain-boundary layer (eps/delta_gb) was fitted together with the seed's law, so reproducing
/// the seed's validation numbers needs it. It underestimates K_i badly for a/r < 0.1 (a small
/// particle on a big one); use fe_table for physics studies with wide size ratios.
///
/// FLOOR: every form returns max(K_law, phi * 4 kappa a), phi = floor_holm_fraction (default
/// 0.01), i.e. never less than 1 % of the Holm constriction conductance of the same neck. So
/// K_i > 0 for every a > 0 (reading A would give K_i <= 0 below a/r = 0.0696), and the floor only
/// acts where the law gives less than phi times the Holm value (reading A with phi = 0.01:
/// a/r < 0.0703; readings B, C and the FE table never reach it for phi <= 0.5). The floor is proportional to a, so it vanishes
/// with the neck: a = 0 gives K_i = 0 for every form (no neck, no branch; readings B/C evaluated
/// at a = 0 would otherwise give a neck-less conductance).
/// Validity of the linear readings: roughly 0.1 <= a/r <= 0.9 (the range of the FE fit).
struct HemisphereLaw {
  enum class Form { Linear, FeTable };
  Form form = Form::Linear;
  double c1 = 1.15;                   ///< slope of Eq. (19) [-] (Linear only)
  double c0 = -0.08;                  ///< intercept of Eq. (19) [-] (Linear only)
  double floor_holm_fraction = 0.01;  ///< phi in (0, 1]: K_i >= phi 4 kappa a [-]

  static HemisphereLaw reading_a() { return {Form::Linear, 1.15, -0.08, 0.01}; }
  static HemisphereLaw reading_b() { return {Form::Linear, 1.15, 0.08, 0.01}; }
  static HemisphereLaw reading_c() { return {Form::Linear, 1.08, 0.15, 0.01}; }
  static HemisphereLaw fe_table() { return {Form::FeTable, 0.0, 0.0, 0.01}; }
};

/// Hemisphere conductance K_i [S] of particle i (radius r_i [m], conductivity kappa [S/m]) for a
/// neck of radius a [m] (seed 000 Eqs. 19-20, see HemisphereLaw):
///   K_i = max(kappa pi r_i k(a/r_i), phi 4 kappa a),  k = c1 x + c0 or k_FE(x);  a = 0 -> 0.
double hemisphere_conductance(const HemisphereLaw& law, double kappa_S_per_m, double r_m, double a_m);

/// Electrical grain-boundary layer in the neck. enabled = false is the seed's "first stage"
/// (no layer, K_c = +inf, K_ij = K_i K_j / (K_i + K_j)).
struct GrainBoundaryLayer {
  bool enabled = false;
  double epsilon = 1.0;      ///< conductivity reduction factor eps in (0, 1] [-]
  double thickness_m = 0.0;  ///< layer thickness delta_gb [m] (> 0); seed: 0.23e-6 with eps = 0.16

  static GrainBoundaryLayer none() { return {}; }
  static GrainBoundaryLayer layer(double epsilon, double thickness_m) { return {true, epsilon, thickness_m}; }
};

/// Grain-boundary-layer conductance of a neck [S] (seed 000 Eq. 26):
///   K_c = eps kappa pi a^2 / delta_gb.
/// Only eps/delta_gb matters (a specific contact conductance h_c = eps kappa/delta_gb [S/m^2]).
/// This delta_gb is the mesoscale porous band (~0.1-0.4 um), NOT the atomic grain-boundary width
/// of the sintering viscosity (§7.10).
inline double grain_boundary_layer_conductance(double kappa_S_per_m, double a_m, double epsilon, double thickness_m) {
  detail::require_positive("conductivity kappa [S/m]", kappa_S_per_m);
  detail::require_nonnegative("neck radius a [m]", a_m);
  if (!(epsilon > 0.0 && epsilon <= 1.0)) detail::invalid("grain-boundary factor epsilon [-]", "in (0, 1]", epsilon);
  detail::require_positive("grain-boundary thickness delta_gb [m]", thickness_m);
  return epsilon * kappa_S_per_m * kPi * a_m * a_m / thickness_m;
}

/// Branch conductance of a sintered neck [S] (seed 000 Eqs. 17-18):
///   K_ij = series(K_i, K_j, K_c),  K_i = hemisphere_conductance(law, kappa_i, r_i, a), same for j,
///   K_c  = Eq. (26) with kappa_gb = eps * 2 kappa_i kappa_j/(kappa_i + kappa_j) if the layer is
///          enabled, else +inf (then K_ij = K_i K_j/(K_i + K_j)).
/// The harmonic mean is the seed's single kappa for one material; for two materials it is the
/// layer split into two half-layers of thickness delta_gb/2, one in each material (own choice).
/// Radii must be finite (a wall has no hemisphere; give the wall side K = +inf through
/// series_conductance instead). a = 0 gives 0.
double sintered_neck_conductance(const HemisphereLaw& law, const GrainBoundaryLayer& layer, double kappa_i_S_per_m, double kappa_j_S_per_m,
                                 double r_i_m, double r_j_m, double a_m);

/// Coble neck radius [m] (seed 000 Eq. 21): a = sqrt(2 r* h), r* = 2 r_i r_j/(r_i + r_j)
/// (= the Bouvard-McMeeking a^2 = 4 R* h). r_j = +inf is a plane (r* = 2 r_i). h <= 0 gives 0.
/// NOT capped: at large h it exceeds min(r_i, r_j) (e.g. 1.045 r_i for r_j = 10 r_i, h = 0.3 r_i);
/// corrected_neck_radii caps at r_min (§7.9). Validity: initial-stage sintering, h << r*.
inline double coble_neck_radius(double r_i_m, double r_j_m, double overlap_m) {
  detail::require_positive("particle radius r_i [m]", r_i_m);
  detail::require_positive_or_inf("particle radius r_j [m]", r_j_m);
  if (std::isnan(overlap_m)) detail::invalid("overlap h [m]", "a number", overlap_m);
  if (!(overlap_m > 0.0)) return 0.0;
  const double r_star = 2.0 / (1.0 / r_i_m + 1.0 / r_j_m);
  return std::sqrt(2.0 * r_star * overlap_m);
}

/// Constant-volume (CV) neck radius [m] (seed 000, after its ref. [36]; geometry rebuilt in
/// sintering-electrical.md §2.5): the overlap (lens) volume of the two spheres is moved into a
/// cylindrical collar of radius a around the radical plane:
///   V_col,i(a) + V_col,j(a) = V_cap,i + V_cap,j,
///   V_cap,k = pi/3 c_k^2 (3 r_k - c_k),  V_col,k = pi/3 (d_k - z_k)^2 (d_k + 2 z_k),
///   d_k = distance centre k -> radical plane, c_k = r_k - d_k, z_k = sqrt(r_k^2 - a^2)
/// (the collar expression is the note's, rearranged without cancellation). With s = a^2 - rho^2
/// (rho = lens radius) the left side is increasing and convex in s with dV/ds = pi sum(d_k - z_k),
/// so the root is found by Newton from the upper end of the bracket [0, s_max], safeguarded by
/// bisection; converged to ~1e-15 relative in a few iterations.
/// Returns 0 for h <= 0, and min(r_i, r_j) when the collar of radius min(r_i, r_j) cannot hold
/// the lens volume (or the radical plane is not between the centres): the §7.9 cap.
/// Reproduces the note's table (equal spheres) and a/r_i = 0.943 for r_j = 10 r_i, h = 0.3 r_i;
/// tends to Coble as h -> 0. Both radii finite.
double cv_neck_radius(double r_i_m, double r_j_m, double overlap_m);

/// Grain-boundary-fraction factors (seed 000 Eqs. 22-25), one per node:
///   alpha_i = min(1, 2 r_i / sqrt(sum_j a_ij^2))
/// (the note's choice of the bound of Eq. 25; alpha_i = 1 for a node without necks or with
/// r_i = +inf, e.g. a wall node). Edges are (edge_a[k], edge_b[k]) with neck radius a[k] >= 0;
/// an edge listed twice counts twice. node_radius_m has one entry per node (> 0, +inf allowed).
std::vector<double> grain_boundary_fraction_factors(std::span<const Index> edge_a, std::span<const Index> edge_b,
                                                    std::span<const double> neck_radius_m, std::span<const double> node_radius_m);

/// Neck radii corrected for the grain-boundary fraction (seed 000 Eqs. 22-25 and §7.9), per edge:
///   a_corr = min(min(alpha_a, alpha_b) a, r_a, r_b).
/// Afterwards every node satisfies sum_j pi a_ij^2 <= 4 pi r_i^2 (Eq. 23), and no neck exceeds
/// the smaller particle. Particles whose necks already satisfy (23) keep them unchanged unless a
/// neighbour is corrected or the neck exceeds r_min. Deterministic (edge order, no threads).
std::vector<double> corrected_neck_radii(std::span<const Index> edge_a, std::span<const Index> edge_b,
                                         std::span<const double> neck_radius_m, std::span<const double> node_radius_m);

// ---------------------------------------------------------------------------------------------
// 3. Transmission surface (seed 001)
// ---------------------------------------------------------------------------------------------

/// A piecewise-linear function y(x) through points with strictly increasing finite x (>= 2
/// points) and finite y. Validated on construction (ConfigError).
class PiecewiseLinear {
 public:
  PiecewiseLinear() = default;
  PiecewiseLinear(std::vector<double> x, std::vector<double> y, const char* name = "table");
  /// y(x), constant beyond the end points.
  double clamped(double x) const;
  /// y(x), the end segments extended linearly beyond the end points.
  double extrapolated(double x) const;
  const std::vector<double>& x() const { return x_; }
  const std::vector<double>& y() const { return y_; }

 private:
  double eval(double x, bool extrapolate) const;
  std::vector<double> x_, y_;
};

/// Transmission-surface model of seed 001 (Eq. 3 and the Terreros alpha(n), f_v(n) curves).
/// DEFAULT (platonic()): the note's reconstruction (§3.3): alpha(n) = face area / r^2 of the
/// regular polyhedron with n faces circumscribed about the sphere, n = 4, 6, 8, 12, 20:
///   alpha = 6 sqrt3, 4, 3 sqrt3/2, 1.38757, 12 sqrt3/(3 + sqrt5)^2 (= 0.75811),
///   f_v   = 4 pi/(n alpha) at those points (0.3023, 0.5236, 0.6046, 0.7547, 0.8288);
/// both interpolated linearly in n, extrapolated linearly below n = 4, with n clamped to
/// [3, 20] (alpha(3) = 13.588 ~ the seed's 13.6). Any other table can replace it (the real
/// Terreros values were not retrievable).
/// Eccentricity factor f(e) = 1 if e < e_face - tol, else eccentric_factor (2): the seed leaves
/// e = 0.4 open and calls it the face-element value, so a face element (e = 0.4 up to round-off)
/// gets 2 (cohesive-joule-torsion.md §3.2); tol keeps round-off from deciding it.
class TransmissionSurfaceModel {
 public:
  /// alpha and f_v tables over n; n is clamped to [n_min, n_max] before evaluation (linear
  /// extrapolation of the end segments inside that range). Throws ConfigError unless
  /// n_min <= n_max, alpha > 0 and f_v > 0 over [n_min, n_max], e_face > 0, tol >= 0,
  /// eccentric_factor >= 1.
  TransmissionSurfaceModel(PiecewiseLinear alpha, PiecewiseLinear volume_fraction, double n_min, double n_max, double e_face,
                           double e_tolerance, double eccentric_factor);
  /// The note's default table (above), e_face = 0.4, tol = 1e-9, factor 2.
  static TransmissionSurfaceModel platonic(double e_tolerance = 1e-9);

  /// alpha(n) [-].
  double alpha(int n) const;
  /// f_v(n) [-], the volume fraction of the table (without the eccentricity factor).
  double volume_fraction_table(int n) const;
  /// f(e) [-]: 1 or eccentric_factor.
  double eccentricity_factor(double e) const;
  /// S_i = alpha(n) r^2 / f(e) [m^2] (Eq. 3).
  double surface(int n, double e, double r_m) const;
  /// f_v,i = f(e) f_v(n) [-] (the seed multiplies, §3.2; used for the Joule-heating mass).
  double volume_fraction(int n, double e) const;

 private:
  double clamp_n(int n) const;
  PiecewiseLinear alpha_, fv_;
  double n_min_ = 3.0, n_max_ = 20.0, e_face_ = 0.4, e_tol_ = 1e-9, factor_ = 2.0;
};

/// Coordination number n_i of every node: the number of edges (edge_a[k], edge_b[k]) that touch
/// it (an edge listed twice counts twice). Nodes are 0..nodes-1.
std::vector<int> coordination_numbers(std::size_t nodes, std::span<const Index> edge_a, std::span<const Index> edge_b);

/// Eccentricity of every node (seed 001 Eq. 2, rebuilt in cohesive-joule-torsion.md §3.1):
///   e_i = | (1/n_i) sum_j x_j - x_i | / r_i   over the neighbours j of the edge list;
/// 0 for a node without neighbours. positions [m] and radii [m] (> 0, finite) one per node.
/// Simple cubic lattice: interior 0, face 0.4, edge 0.707, corner 1.155.
std::vector<double> eccentricities(std::span<const Vec3> positions_m, std::span<const double> radii_m, std::span<const Index> edge_a,
                                   std::span<const Index> edge_b);

/// S_i [m^2] of every node from the edge list (coordination and eccentricity from the same
/// edges), Eq. (3).
std::vector<double> transmission_surfaces(const TransmissionSurfaceModel& model, std::span<const Vec3> positions_m,
                                          std::span<const double> radii_m, std::span<const Index> edge_a, std::span<const Index> edge_b);

/// The same with the eccentricities given (e.g. of a reference state), the coordination from the
/// edges.
std::vector<double> transmission_surfaces(const TransmissionSurfaceModel& model, std::span<const double> eccentricity,
                                          std::span<const double> radii_m, std::span<const Index> edge_a, std::span<const Index> edge_b);

/// Branch resistance of seed 001 [Ohm] (Eqs. 4-5): R_ij = rho_e l_ij / sqrt(S_i S_j),
/// l_ij = centre distance [m] (> 0), S [m^2] (> 0), rho_e bulk resistivity [Ohm m] (> 0).
/// On a simple cubic lattice (S = 4 r^2, l = 2 r) this is rho_e/(2 r) per branch, which
/// reproduces the continuum resistance rho_e L/A exactly (§3.4).
inline double transmission_resistance(double rho_e_Ohm_m, double length_m, double s_i_m2, double s_j_m2) {
  detail::require_positive("resistivity rho_e [Ohm m]", rho_e_Ohm_m);
  detail::require_positive("centre distance l_ij [m]", length_m);
  detail::require_positive("transmission surface S_i [m^2]", s_i_m2);
  detail::require_positive("transmission surface S_j [m^2]", s_j_m2);
  return rho_e_Ohm_m * length_m / std::sqrt(s_i_m2 * s_j_m2);
}
/// 1 / transmission_resistance [S].
inline double transmission_conductance(double rho_e_Ohm_m, double length_m, double s_i_m2, double s_j_m2) {
  return 1.0 / transmission_resistance(rho_e_Ohm_m, length_m, s_i_m2, s_j_m2);
}

// ---------------------------------------------------------------------------------------------
// 4. Touching on/off and tunnelling
// ---------------------------------------------------------------------------------------------

/// On/off contact conductance [S] (seed 002, cpc-and-networks.md §1.3-1.4): g_unit if
/// overlap >= -tolerance, else 0. overlap = r_i + r_j - d [m] (> 0 overlap, < 0 gap, as on the
/// graph edges); tolerance >= 0 [m] (seed 002: 0.1 % of the filler diameter). g_unit defaults
/// to 1 (the seed's dimensionless unit conductance).
inline double touching_conductance(double overlap_m, double tolerance_m, double g_unit_S = 1.0) {
  if (std::isnan(overlap_m)) detail::invalid("overlap [m]", "a number", overlap_m);
  detail::require_nonnegative("touching tolerance [m]", tolerance_m);
  detail::require_positive("unit conductance [S]", g_unit_S);
  return overlap_m >= -tolerance_m ? g_unit_S : 0.0;
}

/// Tunnelling conductance [S] (cpc-and-networks.md §1.3, the g = g0 exp(-2 delta/xi) form of
/// the Grimaldi/Balberg literature, not used by seed 002 itself):
///   G = g0 exp(-2 max(gap, 0)/xi) for gap <= cut-off, 0 for gap > cut-off.
/// gap = surface gap [m] (= -overlap of a graph edge); an overlapping pair (gap < 0) gets the
/// contact value g0. xi = decay length [m] (> 0; typically 0.1-few nm); cut-off >= 0 [m], +inf
/// for none (the graph's near_gap should be >= the cut-off so that every pair is seen).
inline double tunnelling_conductance(double gap_m, double g0_S, double xi_m, double cutoff_gap_m) {
  if (std::isnan(gap_m)) detail::invalid("gap [m]", "a number", gap_m);
  detail::require_positive("tunnelling prefactor g0 [S]", g0_S);
  detail::require_positive("tunnelling decay length xi [m]", xi_m);
  if (!(cutoff_gap_m >= 0.0)) detail::invalid("tunnelling cut-off gap [m]", ">= 0 (+inf allowed)", cutoff_gap_m);
  if (gap_m > cutoff_gap_m) return 0.0;
  return g0_S * std::exp(-2.0 * (gap_m > 0.0 ? gap_m : 0.0) / xi_m);
}

// ---------------------------------------------------------------------------------------------
// 5. Temperature-dependent bulk conductivity
// ---------------------------------------------------------------------------------------------

/// Linear-resistivity law (the usual metal law near room temperature):
///   rho(T) = rho_ref (1 + beta (T - T_ref)),  kappa(T) = kappa_ref / (1 + beta (T - T_ref)).
/// beta [1/K] is the temperature coefficient of resistivity (Cu ~ 3.9e-3). Valid while
/// 1 + beta (T - T_ref) > 0; outside it conductivity() throws. Which T the caller evaluates at
/// (e.g. 293.15 K for a room-temperature measurement, seed 000 §7.11) is the caller's business.
struct LinearResistivityLaw {
  double kappa_ref_S_per_m = 0.0;  ///< kappa(T_ref) [S/m] (> 0)
  double beta_per_K = 0.0;         ///< temperature coefficient of resistivity [1/K]
  double t_ref_K = 293.15;         ///< reference temperature [K]
};

/// Tabulated kappa(T): piecewise linear in T, constant beyond the end points. T strictly
/// increasing (>= 2 points), kappa > 0 and finite; checked on construction (ConfigError).
class ConductivityTable {
 public:
  ConductivityTable(std::vector<double> t_K, std::vector<double> kappa_S_per_m);
  double operator()(double t_K) const { return table_.clamped(t_K); }
  const PiecewiseLinear& table() const { return table_; }

 private:
  PiecewiseLinear table_;
};

using ConductivityLaw = std::variant<LinearResistivityLaw, ConductivityTable>;

/// kappa(T) [S/m] of either law. T [K] must be finite (> 0 for the linear law). Throws
/// ConfigError on invalid parameters or when the linear law's denominator is <= 0.
double conductivity(const ConductivityLaw& law, double t_K);

}  // namespace sparkdem::physics::electrical
