#include "physics/electrical/conductance_kernels.hpp"

#include <algorithm>
#include <array>
#include <sstream>
#include <string>
#include <utility>
#include "engine/core/format.hpp"

namespace sparkdem::physics::electrical {

namespace {


/// Linear interpolation in sorted x (size >= 2); beyond the ends: the end value (clamp) or the
/// end segment extended (extrapolate).
double interpolate(std::span<const double> x, std::span<const double> y, double q, bool extrapolate) {
  const std::size_t n = x.size();
  if (!extrapolate) {
    if (q <= x[0]) return y[0];
    if (q >= x[n - 1]) return y[n - 1];
  }
  // Segment k = [x[k], x[k+1]] with x[k] <= q < x[k+1], limited to the first/last segment.
  const auto it = std::upper_bound(x.begin(), x.end(), q);
  std::size_t k = it == x.begin() ? 0 : static_cast<std::size_t>(it - x.begin()) - 1;
  k = std::min(k, n - 2);
  const double t = (q - x[k]) / (x[k + 1] - x[k]);
  return y[k] + t * (y[k + 1] - y[k]);
}

/// The note's FE table of K_i/(kappa pi r) versus a/r (sintering-electrical.md §2.4).
constexpr std::array<double, 13> kFeX = {0.05, 0.10, 0.15, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 0.95, 0.99};
constexpr std::array<double, 13> kFeK = {0.059, 0.113, 0.166, 0.216, 0.316, 0.418, 0.525, 0.642, 0.775, 0.936, 1.149, 1.293, 1.449};

void check_edges(std::span<const Index> edge_a, std::span<const Index> edge_b, std::size_t nodes) {
  if (edge_a.size() != edge_b.size())
    throw ConfigError("", "edge lists differ in length: " + std::to_string(edge_a.size()) + " end points a, " +
                              std::to_string(edge_b.size()) + " end points b");
  for (std::size_t k = 0; k < edge_a.size(); ++k) {
    const Index u = edge_a[k], v = edge_b[k];
    if (u < 0 || v < 0 || static_cast<std::size_t>(u) >= nodes || static_cast<std::size_t>(v) >= nodes)
      throw ConfigError("", "edge " + std::to_string(k) + " (" + std::to_string(u) + ", " + std::to_string(v) +
                                ") refers to a node outside 0.." + std::to_string(nodes) + "-1");
  }
}

void check_necks(std::span<const Index> edge_a, std::span<const double> neck_radius_m, std::span<const double> node_radius_m) {
  if (neck_radius_m.size() != edge_a.size())
    throw ConfigError("", "neck radii: " + std::to_string(neck_radius_m.size()) + " values for " + std::to_string(edge_a.size()) + " edges");
  for (const double a : neck_radius_m) detail::require_nonnegative("neck radius [m]", a);
  for (const double r : node_radius_m) detail::require_positive_or_inf("node radius [m]", r);
}

}  // namespace

namespace detail {
void invalid(const char* what, const char* expected, double value) {
  throw ConfigError("", std::string(what) + " must be " + expected + ", found " + format_number(value, 12));
}
}  // namespace detail

// ----------------------------------------------------------------------------------------------
// Sintered neck
// ----------------------------------------------------------------------------------------------

double fe_hemisphere_normalised(double x) {
  if (!(x >= 0.0)) detail::invalid("a/r", ">= 0", x);
  if (x == 0.0) return 0.0;
  if (x < kFeX.front()) {
    // Holm constriction 4 kappa a, i.e. k = 4x/pi, in series with a bulk term c_b chosen so that
    // k is continuous at the first table point.
    const double c_b = 1.0 / kFeK.front() - kPi / (4.0 * kFeX.front());
    return 1.0 / (kPi / (4.0 * x) + c_b);
  }
  return interpolate(kFeX, kFeK, std::min(x, 1.0), true);
}

double hemisphere_conductance(const HemisphereLaw& law, double kappa_S_per_m, double r_m, double a_m) {
  detail::require_positive("conductivity kappa [S/m]", kappa_S_per_m);
  detail::require_positive("particle radius r [m]", r_m);
  detail::require_nonnegative("neck radius a [m]", a_m);
  if (!(law.floor_holm_fraction > 0.0 && law.floor_holm_fraction <= 1.0))
    detail::invalid("hemisphere floor fraction phi [-]", "in (0, 1]", law.floor_holm_fraction);
  if (a_m == 0.0) return 0.0;
  const double x = a_m / r_m;
  double k = 0.0;
  switch (law.form) {
    case HemisphereLaw::Form::Linear:
      if (!std::isfinite(law.c1)) detail::invalid("hemisphere slope c1 [-]", "finite", law.c1);
      if (!std::isfinite(law.c0)) detail::invalid("hemisphere intercept c0 [-]", "finite", law.c0);
      k = law.c1 * x + law.c0;
      break;
    case HemisphereLaw::Form::FeTable:
      k = fe_hemisphere_normalised(x);
      break;
  }
  const double k_law = kappa_S_per_m * kPi * r_m * k;
  const double k_floor = law.floor_holm_fraction * 4.0 * kappa_S_per_m * a_m;
  return std::max(k_law, k_floor);
}

double sintered_neck_conductance(const HemisphereLaw& law, const GrainBoundaryLayer& layer, double kappa_i_S_per_m, double kappa_j_S_per_m,
                                 double r_i_m, double r_j_m, double a_m) {
  const double k_i = hemisphere_conductance(law, kappa_i_S_per_m, r_i_m, a_m);
  const double k_j = hemisphere_conductance(law, kappa_j_S_per_m, r_j_m, a_m);
  double k_c = kInf;
  if (layer.enabled) {
    const double kappa_h = 2.0 * kappa_i_S_per_m * kappa_j_S_per_m / (kappa_i_S_per_m + kappa_j_S_per_m);
    k_c = grain_boundary_layer_conductance(kappa_h, a_m, layer.epsilon, layer.thickness_m);
  }
  return series_conductance(k_i, k_j, k_c);
}

double cv_neck_radius(double r_i_m, double r_j_m, double overlap_m) {
  detail::require_positive("particle radius r_i [m]", r_i_m);
  detail::require_positive("particle radius r_j [m]", r_j_m);
  if (std::isnan(overlap_m)) detail::invalid("overlap h [m]", "a number", overlap_m);
  if (!(overlap_m > 0.0)) return 0.0;
  const double h = overlap_m;
  const double r_min = std::min(r_i_m, r_j_m);
  const double dist = r_i_m + r_j_m - h;                // centre distance D
  if (!(dist > std::abs(r_i_m - r_j_m))) return r_min;  // one sphere inside the other
  // Cap heights c_k = r_k - d_k without cancellation, d_k = centre k -> radical plane.
  const double c_i = h * (r_j_m + dist - r_i_m) / (2.0 * dist);
  const double c_j = h * (r_i_m + dist - r_j_m) / (2.0 * dist);
  const double d_i = r_i_m - c_i, d_j = r_j_m - c_j;
  if (!(d_i > 0.0 && d_j > 0.0)) return r_min;  // radical plane not between the centres
  const double rho2 = h * (dist - r_i_m + r_j_m) * (dist + r_i_m - r_j_m) * (dist + r_i_m + r_j_m) / (4.0 * dist * dist);  // lens radius^2
  const double v_caps = kPi / 3.0 * (c_i * c_i * (3.0 * r_i_m - c_i) + c_j * c_j * (3.0 * r_j_m - c_j));

  // Collar volume on one side as a function of s = a^2 - rho^2 in [0, d^2]:
  // z = sqrt(d^2 - s), L = d - z = s/(d + z), V = pi/3 L^2 (d + 2z), dV/ds = pi L.
  struct Side {
    double v, dv;
  };
  auto collar = [](double s, double d) {
    const double z = std::sqrt(std::max(d * d - s, 0.0));
    const double len = s / (d + z);
    return Side{kPi / 3.0 * len * len * (d + 2.0 * z), kPi * len};
  };
  const double s_max = std::min(d_i * d_i, d_j * d_j);  // a <= min(r_i, r_j)
  auto f = [&](double s, double* df) {
    const Side a = collar(s, d_i), b = collar(s, d_j);
    if (df) *df = a.dv + b.dv;
    return a.v + b.v - v_caps;
  };
  if (f(s_max, nullptr) <= 0.0) return r_min;  // the widest collar cannot hold the lens

  // f is increasing and convex on [0, s_max], f(0) < 0 < f(s_max). Newton from the Coble guess
  // (the Coble neck is wider than the CV neck, so usually f > 0 there and Newton then decreases
  // monotonically to the root), safeguarded by the bracket [lo, hi] and bisection.
  double lo = 0.0, hi = s_max;
  const double r_star = 2.0 * r_i_m * r_j_m / (r_i_m + r_j_m);
  double s = 2.0 * r_star * h - rho2;
  if (!(s > lo && s < hi)) s = hi;
  for (int it = 0; it < 200; ++it) {
    double df = 0.0;
    const double fs = f(s, &df);
    if (fs == 0.0) break;
    if (fs > 0.0)
      hi = s;
    else
      lo = s;
    double s_new = df > 0.0 ? s - fs / df : 0.5 * (lo + hi);
    if (!(s_new > lo && s_new < hi)) s_new = 0.5 * (lo + hi);
    const bool done = std::abs(s_new - s) <= 1e-15 * s_new || !(hi - lo > 1e-15 * hi);
    s = s_new;
    if (done) break;
  }
  return std::min(std::sqrt(rho2 + s), r_min);
}

std::vector<double> grain_boundary_fraction_factors(std::span<const Index> edge_a, std::span<const Index> edge_b,
                                                    std::span<const double> neck_radius_m, std::span<const double> node_radius_m) {
  check_edges(edge_a, edge_b, node_radius_m.size());
  check_necks(edge_a, neck_radius_m, node_radius_m);
  std::vector<double> sum_a2(node_radius_m.size(), 0.0);
  for (std::size_t k = 0; k < edge_a.size(); ++k) {
    const double a2 = neck_radius_m[k] * neck_radius_m[k];
    sum_a2[static_cast<std::size_t>(edge_a[k])] += a2;
    sum_a2[static_cast<std::size_t>(edge_b[k])] += a2;
  }
  std::vector<double> alpha(node_radius_m.size(), 1.0);
  for (std::size_t i = 0; i < alpha.size(); ++i) {
    const double r = node_radius_m[i];
    if (sum_a2[i] > 0.0 && std::isfinite(r)) alpha[i] = std::min(1.0, 2.0 * r / std::sqrt(sum_a2[i]));
  }
  return alpha;
}

std::vector<double> corrected_neck_radii(std::span<const Index> edge_a, std::span<const Index> edge_b,
                                         std::span<const double> neck_radius_m, std::span<const double> node_radius_m) {
  const std::vector<double> alpha = grain_boundary_fraction_factors(edge_a, edge_b, neck_radius_m, node_radius_m);
  std::vector<double> out(neck_radius_m.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    const auto u = static_cast<std::size_t>(edge_a[k]), v = static_cast<std::size_t>(edge_b[k]);
    const double scaled = std::min(alpha[u], alpha[v]) * neck_radius_m[k];
    out[k] = std::min({scaled, node_radius_m[u], node_radius_m[v]});
  }
  return out;
}

// ----------------------------------------------------------------------------------------------
// Transmission surface
// ----------------------------------------------------------------------------------------------

PiecewiseLinear::PiecewiseLinear(std::vector<double> x, std::vector<double> y, const char* name) : x_(std::move(x)), y_(std::move(y)) {
  const std::string n(name);
  if (x_.size() != y_.size())
    throw ConfigError("", n + ": " + std::to_string(x_.size()) + " abscissae but " + std::to_string(y_.size()) + " values");
  if (x_.size() < 2) throw ConfigError("", n + ": needs at least 2 points, found " + std::to_string(x_.size()));
  for (std::size_t k = 0; k < x_.size(); ++k) {
    if (!std::isfinite(x_[k])) throw ConfigError("", n + ": abscissa " + std::to_string(k) + " is " + format_number(x_[k], 12));
    if (!std::isfinite(y_[k])) throw ConfigError("", n + ": value " + std::to_string(k) + " is " + format_number(y_[k], 12));
    if (k > 0 && !(x_[k] > x_[k - 1]))
      throw ConfigError(
          "", n + ": abscissae must increase strictly, found " + format_number(x_[k - 1], 12) + " then " + format_number(x_[k], 12) + " at point " + std::to_string(k));
  }
}

double PiecewiseLinear::eval(double x, bool extrapolate) const {
  if (x_.size() < 2) throw ConfigError("", "piecewise-linear table evaluated before it was set");
  if (std::isnan(x)) detail::invalid("table abscissa", "a number", x);
  return interpolate(x_, y_, x, extrapolate);
}
double PiecewiseLinear::clamped(double x) const { return eval(x, false); }
double PiecewiseLinear::extrapolated(double x) const { return eval(x, true); }

TransmissionSurfaceModel::TransmissionSurfaceModel(PiecewiseLinear alpha, PiecewiseLinear volume_fraction, double n_min, double n_max,
                                                   double e_face, double e_tolerance, double eccentric_factor)
    : alpha_(std::move(alpha)),
      fv_(std::move(volume_fraction)),
      n_min_(n_min),
      n_max_(n_max),
      e_face_(e_face),
      e_tol_(e_tolerance),
      factor_(eccentric_factor) {
  if (!std::isfinite(n_min_) || !std::isfinite(n_max_) || !(n_min_ <= n_max_))
    throw ConfigError("", "transmission surface: need finite n_min <= n_max, found " + format_number(n_min_, 12) + ", " + format_number(n_max_, 12));
  if (!(e_face_ > 0.0) || std::isinf(e_face_)) detail::invalid("face eccentricity threshold [-]", "> 0", e_face_);
  detail::require_nonnegative("eccentricity tolerance [-]", e_tol_);
  if (!(factor_ >= 1.0) || std::isinf(factor_)) detail::invalid("eccentricity factor [-]", ">= 1 and finite", factor_);
  // Piecewise linear: the minimum over [n_min, n_max] is at an end or at a break point inside.
  auto check = [&](const PiecewiseLinear& t, const char* what) {
    std::vector<double> at = {n_min_, n_max_};
    for (const double x : t.x())
      if (x > n_min_ && x < n_max_) at.push_back(x);
    for (const double x : at)
      if (!(t.extrapolated(x) > 0.0))
        throw ConfigError("", std::string("transmission surface: ") + what + " must be > 0 on [n_min, n_max], found " +
                                  format_number(t.extrapolated(x), 12) + " at n = " + format_number(x, 12));
  };
  check(alpha_, "alpha(n)");
  check(fv_, "f_v(n)");
}

TransmissionSurfaceModel TransmissionSurfaceModel::platonic(double e_tolerance) {
  const double s3 = std::sqrt(3.0), s5 = std::sqrt(5.0);
  // Face area / inradius^2 of the regular polyhedra (edge length 1):
  //  tetrahedron 6 sqrt3; cube 4; octahedron 3 sqrt3 / 2;
  //  dodecahedron: face sqrt(25 + 10 sqrt5)/4, inradius sqrt(250 + 110 sqrt5)/20;
  //  icosahedron: face sqrt3/4, inradius sqrt3 (3 + sqrt5)/12  ->  12 sqrt3/(3 + sqrt5)^2.
  const double a12 = std::sqrt(25.0 + 10.0 * s5) / 4.0 * 400.0 / (250.0 + 110.0 * s5);
  const double a20 = 12.0 * s3 / ((3.0 + s5) * (3.0 + s5));
  std::vector<double> n = {4.0, 6.0, 8.0, 12.0, 20.0};
  std::vector<double> alpha = {6.0 * s3, 4.0, 1.5 * s3, a12, a20};
  std::vector<double> fv(n.size());
  for (std::size_t k = 0; k < n.size(); ++k) fv[k] = 4.0 * kPi / (n[k] * alpha[k]);
  return TransmissionSurfaceModel(PiecewiseLinear(n, std::move(alpha), "alpha(n)"), PiecewiseLinear(n, std::move(fv), "f_v(n)"), 3.0, 20.0,
                                  0.4, e_tolerance, 2.0);
}

double TransmissionSurfaceModel::clamp_n(int n) const { return std::clamp(static_cast<double>(n), n_min_, n_max_); }
double TransmissionSurfaceModel::alpha(int n) const { return alpha_.extrapolated(clamp_n(n)); }
double TransmissionSurfaceModel::volume_fraction_table(int n) const { return fv_.extrapolated(clamp_n(n)); }
double TransmissionSurfaceModel::eccentricity_factor(double e) const {
  if (!(e >= 0.0) || std::isinf(e)) detail::invalid("eccentricity e [-]", ">= 0 and finite", e);
  return e >= e_face_ - e_tol_ ? factor_ : 1.0;
}
double TransmissionSurfaceModel::surface(int n, double e, double r_m) const {
  detail::require_positive("particle radius r [m]", r_m);
  return alpha(n) * r_m * r_m / eccentricity_factor(e);
}
double TransmissionSurfaceModel::volume_fraction(int n, double e) const { return eccentricity_factor(e) * volume_fraction_table(n); }

std::vector<int> coordination_numbers(std::size_t nodes, std::span<const Index> edge_a, std::span<const Index> edge_b) {
  check_edges(edge_a, edge_b, nodes);
  std::vector<int> n(nodes, 0);
  for (std::size_t k = 0; k < edge_a.size(); ++k) {
    ++n[static_cast<std::size_t>(edge_a[k])];
    ++n[static_cast<std::size_t>(edge_b[k])];
  }
  return n;
}

std::vector<double> eccentricities(std::span<const Vec3> positions_m, std::span<const double> radii_m, std::span<const Index> edge_a,
                                   std::span<const Index> edge_b) {
  if (positions_m.size() != radii_m.size())
    throw ConfigError(
        "", "eccentricities: " + std::to_string(positions_m.size()) + " positions but " + std::to_string(radii_m.size()) + " radii");
  check_edges(edge_a, edge_b, positions_m.size());
  for (const double r : radii_m) detail::require_positive("particle radius [m]", r);
  std::vector<Vec3> sum(positions_m.size(), Vec3::Zero());
  std::vector<int> count(positions_m.size(), 0);
  for (std::size_t k = 0; k < edge_a.size(); ++k) {
    const auto u = static_cast<std::size_t>(edge_a[k]), v = static_cast<std::size_t>(edge_b[k]);
    sum[u] += positions_m[v];
    sum[v] += positions_m[u];
    ++count[u];
    ++count[v];
  }
  std::vector<double> e(positions_m.size(), 0.0);
  for (std::size_t i = 0; i < e.size(); ++i) {
    if (count[i] == 0) continue;
    if (!positions_m[i].allFinite()) throw ConfigError("", "eccentricities: position " + std::to_string(i) + " is not finite");
    e[i] = (sum[i] / count[i] - positions_m[i]).norm() / radii_m[i];
    if (!std::isfinite(e[i]))
      throw ConfigError("", "eccentricities: a neighbour of node " + std::to_string(i) + " has a non-finite position");
  }
  return e;
}

std::vector<double> transmission_surfaces(const TransmissionSurfaceModel& model, std::span<const Vec3> positions_m,
                                          std::span<const double> radii_m, std::span<const Index> edge_a, std::span<const Index> edge_b) {
  return transmission_surfaces(model, eccentricities(positions_m, radii_m, edge_a, edge_b), radii_m, edge_a, edge_b);
}

std::vector<double> transmission_surfaces(const TransmissionSurfaceModel& model, std::span<const double> eccentricity,
                                          std::span<const double> radii_m, std::span<const Index> edge_a, std::span<const Index> edge_b) {
  if (eccentricity.size() != radii_m.size())
    throw ConfigError("", "transmission_surfaces: " + std::to_string(eccentricity.size()) + " eccentricities but " +
                              std::to_string(radii_m.size()) + " radii");
  const std::vector<int> n = coordination_numbers(radii_m.size(), edge_a, edge_b);
  std::vector<double> s(radii_m.size());
  for (std::size_t i = 0; i < s.size(); ++i) s[i] = model.surface(n[i], eccentricity[i], radii_m[i]);
  return s;
}

// ----------------------------------------------------------------------------------------------
// Conductivity
// ----------------------------------------------------------------------------------------------

ConductivityTable::ConductivityTable(std::vector<double> t_K, std::vector<double> kappa_S_per_m)
    : table_(std::move(t_K), std::move(kappa_S_per_m), "conductivity table kappa(T)") {
  for (const double k : table_.y()) detail::require_positive("tabulated conductivity [S/m]", k);
}

double conductivity(const ConductivityLaw& law, double t_K) {
  detail::require_positive("temperature T [K]", t_K);
  if (const auto* lin = std::get_if<LinearResistivityLaw>(&law)) {
    detail::require_positive("reference conductivity kappa_ref [S/m]", lin->kappa_ref_S_per_m);
    detail::require_positive("reference temperature T_ref [K]", lin->t_ref_K);
    if (!std::isfinite(lin->beta_per_K)) detail::invalid("resistivity coefficient beta [1/K]", "finite", lin->beta_per_K);
    const double denom = 1.0 + lin->beta_per_K * (t_K - lin->t_ref_K);
    if (!(denom > 0.0))
      throw ConfigError("", "linear resistivity law: 1 + beta (T - T_ref) = " + format_number(denom, 12) + " <= 0 at T = " + format_number(t_K, 12) + " K (beta = " +
                                format_number(lin->beta_per_K, 12) + " 1/K, T_ref = " + format_number(lin->t_ref_K, 12) + " K): outside the law's range");
    return lin->kappa_ref_S_per_m / denom;
  }
  return std::get<ConductivityTable>(law)(t_K);
}

}  // namespace sparkdem::physics::electrical
