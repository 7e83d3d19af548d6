#include "physics/packing/packing_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include "engine/core/numbers.hpp"
#include "engine/core/format.hpp"

namespace sparkdem::physics {
namespace {



// ---------------------------------------------------------------- argument checks

void check_particles(const std::vector<Vec3>& positions, const std::vector<double>& radii) {
  if (positions.size() != radii.size())
    throw ConfigError(
        "", "positions (" + std::to_string(positions.size()) + ") and radii (" + std::to_string(radii.size()) + ") differ in length");
  for (std::size_t i = 0; i < radii.size(); ++i) {
    if (!std::isfinite(radii[i]) || radii[i] <= 0.0)
      throw ConfigError("", "radius of particle " + std::to_string(i) + " must be positive and finite [m], found " + format_number(radii[i], 12));
    if (!positions[i].allFinite()) throw ConfigError("", "position of particle " + std::to_string(i) + " is not finite");
  }
}

void check_pair(const std::array<Index, 2>& p, std::size_t n, std::size_t k) {
  const auto bad = [n](Index i) { return i < 0 || static_cast<std::size_t>(i) >= n; };
  if (bad(p[0]) || bad(p[1]) || p[0] == p[1])
    throw ConfigError("", "pair " + std::to_string(k) + " (" + std::to_string(p[0]) + ", " + std::to_string(p[1]) +
                              ") is not a pair of distinct particles among " + std::to_string(n));
}

// ---------------------------------------------------------------- closed-form pieces

/// Volume of a sphere of radius r between the planes t = a and t = b (offsets from the centre,
/// -r <= a <= b <= r):
///   V = pi int_a^b (r^2 - t^2) dt = pi (b - a) (r^2 - (a^2 + a b + b^2) / 3).
/// For a cap of height h (a = r - h, b = r) this is pi h^2 (3r - h) / 3.
double slab_volume(double r, double a, double b) {
  if (b <= a) return 0.0;
  return kPi * (b - a) * (r * r - (a * a + a * b + b * b) / 3.0);
}

/// sqrt(rho^2 - u^2) written as sqrt((rho - u)(rho + u)) to avoid cancellation near |u| = rho.
double half_chord(double rho, double u) { return std::sqrt(std::max(0.0, (rho - u) * (rho + u))); }

/// Area of the disc x^2 + y^2 <= rho^2 with y >= Y (circular segment):
///   A = rho^2 acos(Y / rho) - Y sqrt(rho^2 - Y^2),  |Y| < rho,
/// with acos(Y / rho) evaluated as atan2(sqrt(rho^2 - Y^2), Y) (well conditioned near |Y| = rho).
double disc_segment(double rho, double y) {
  if (y >= rho) return 0.0;
  if (y <= -rho) return kPi * rho * rho;
  const double h = half_chord(rho, y);
  return rho * rho * std::atan2(h, y) - y * h;
}

/// Area of the disc x^2 + y^2 <= rho^2 with x >= X and y >= Y. For X, Y >= 0 and X^2 + Y^2 < rho^2:
///   A = int_X^{x1} (sqrt(rho^2 - x^2) - Y) dx = P(x1) - P(X) - Y (x1 - X),
///   x1 = sqrt(rho^2 - Y^2),  P(x) = (x sqrt(rho^2 - x^2) + rho^2 asin(x / rho)) / 2,
/// with asin(x / rho) = atan2(x, sqrt(rho^2 - x^2)) (note sqrt(rho^2 - x1^2) = Y).
/// Negative X (or Y) by reflection: A(X, Y) = segment(Y) - A(-X, Y).
double disc_corner(double rho, double x, double y) {
  if (x < 0.0) return disc_segment(rho, y) - disc_corner(rho, -x, y);
  if (y < 0.0) return disc_segment(rho, x) - disc_corner(rho, x, -y);
  if (x * x + y * y >= rho * rho) return 0.0;
  const double x1 = half_chord(rho, y);
  const double sx = half_chord(rho, x);
  const double p1 = 0.5 * (x1 * y + rho * rho * std::atan2(x1, y));
  const double p0 = 0.5 * (x * sx + rho * rho * std::atan2(x, sx));
  return p1 - p0 - y * (x1 - x);
}

/// Area of the disc of radius rho centred at the origin inside [x0, x1] x [y0, y1] by
/// inclusion-exclusion of corner areas: A = C(x0,y0) - C(x1,y0) - C(x0,y1) + C(x1,y1).
double disc_rectangle(double rho, double x0, double x1, double y0, double y1) {
  if (rho <= 0.0 || x1 <= x0 || y1 <= y0) return 0.0;
  const auto c = [rho](double x, double y) { return disc_corner(rho, std::clamp(x, -rho, rho), std::clamp(y, -rho, rho)); };
  return std::max(0.0, c(x0, y0) - c(x1, y0) - c(x0, y1) + c(x1, y1));
}

/// Intersection (lens) area of two circles of radii rho and R with centres q apart:
///   q >= rho + R: 0;   q <= |R - rho|: pi min(rho, R)^2;   otherwise
///   A = rho^2 alpha + R^2 beta - sqrt(k) / 2,
///   k = (-q + rho + R)(q + rho - R)(q - rho + R)(q + rho + R)   (16 x triangle area^2),
///   alpha = acos((q^2 + rho^2 - R^2) / (2 q rho)) = atan2(sqrt(k), q^2 + rho^2 - R^2),
///   beta  = acos((q^2 + R^2 - rho^2) / (2 q R))   = atan2(sqrt(k), q^2 + R^2 - rho^2)
/// (half-angles subtended by the common chord; the atan2 forms stay accurate near tangency).
double lens_area(double rho, double big_r, double q) {
  if (rho <= 0.0 || q >= rho + big_r) return 0.0;
  if (q <= std::abs(big_r - rho)) {
    const double m = std::min(rho, big_r);
    return kPi * m * m;
  }
  const double k = (-q + rho + big_r) * (q + rho - big_r) * (q - rho + big_r) * (q + rho + big_r);
  const double sk = std::sqrt(std::max(0.0, k));
  const double alpha = std::atan2(sk, q * q + (rho - big_r) * (rho + big_r));
  const double beta = std::atan2(sk, q * q + (big_r - rho) * (big_r + rho));
  return rho * rho * alpha + big_r * big_r * beta - 0.5 * sk;
}

// ---------------------------------------------------------------- quadrature

constexpr int kGaussPoints = 24;

struct GaussLegendre {
  std::array<double, kGaussPoints> x{}, w{};  ///< nodes and weights on [-1, 1]
  GaussLegendre() {
    // Newton iteration on P_n from the Chebyshev-like initial guess cos(pi (i + 3/4) / (n + 1/2)).
    const int n = kGaussPoints;
    for (int i = 0; i < n; ++i) {
      double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
      double dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = z;  // P_0, P_1; recurrence k P_k = (2k-1) z P_{k-1} - (k-1) P_{k-2}
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (z * p1 - p0) / (z * z - 1.0);  // P_n'
        const double dz = p1 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-16) break;
      }
      x[i] = z;
      w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
  }
};

const GaussLegendre& gauss_legendre() {
  static const GaussLegendre g;
  return g;
}

/// Volume of the slices of a sphere (radius r) between axial offsets a <= t <= b (from the
/// centre), V = int_a^b A(rho(t)) dt, where A(rho) is the area of the slice disc of radius
/// rho(t) = sqrt(r^2 - t^2) inside the region's cross-section.
///
/// Variable: the polar angle phi, t = -r cos(phi), rho = r sin(phi), dt = r sin(phi) dphi, so
///   V = int_{phi_a}^{phi_b} A(r sin phi) r sin phi dphi.
/// rho(phi) is analytic (rho(t) has square-root branch points at the poles t = +-r, which would
/// spoil the quadrature of slices near a pole). A(rho) changes form where rho equals one of the
/// `rho_breaks` (distances from the slice centre to edges / corners of the cross-section); the
/// phi range is split there (phi* = asin(rho* / r) and pi - phi*), and at the equator phi = pi/2
/// (a breakpoint rho* slightly above r puts a complex singularity near pi/2, which then lies next
/// to a piece end, where the nodes cluster). On each piece [p0, p1] the
/// substitution phi = p0 + (p1 - p0)(1 - cos theta)/2, theta in [0, pi], turns the
/// (phi - phi*)^{3/2} behaviour at a breakpoint (a slice starting to cross an edge) into a smooth
/// function of theta, which Gauss-Legendre integrates to about machine precision.
template <class F>
double integrate_slices(double r, double a, double b, const std::vector<double>& rho_breaks, const F& area) {
  if (b <= a) return 0.0;
  // phi = atan2(sqrt(r^2 - t^2), -t): accurate near the poles, unlike acos(-t / r)
  const double pa = std::atan2(half_chord(r, a), -a), pb = std::atan2(half_chord(r, b), -b);
  std::vector<double> breaks{pb, 0.5 * kPi};
  for (double rho : rho_breaks) {
    if (!(rho > 0.0 && rho < r)) continue;
    const double ps = std::atan2(rho, half_chord(r, rho));
    breaks.push_back(ps);
    breaks.push_back(kPi - ps);
  }
  std::sort(breaks.begin(), breaks.end());
  const auto& g = gauss_legendre();
  double sum = 0.0;
  double p0 = pa;
  for (double p1 : breaks) {
    if (p1 <= p0) continue;
    p1 = std::min(p1, pb);
    double piece = 0.0;
    for (int i = 0; i < kGaussPoints; ++i) {
      const double theta = 0.5 * kPi * (g.x[i] + 1.0);
      const double phi = p0 + 0.5 * (p1 - p0) * (1.0 - std::cos(theta));
      const double rho = r * std::sin(phi);
      piece += g.w[i] * area(rho) * rho * std::sin(theta);
    }
    sum += piece * 0.5 * kPi * 0.5 * (p1 - p0);
    p0 = p1;
    if (p0 >= pb) break;
  }
  return sum;
}

// ---------------------------------------------------------------- per-shape volumes

/// Sphere (centre c, radius r) inside an axis-aligned box.
double sphere_in_box(const Vec3& c, double r, const BoxRegion& b) {
  int cut_axes = 0, cut_axis = -1;
  for (int k = 0; k < 3; ++k) {
    if (c[k] + r <= b.lo[k] || c[k] - r >= b.hi[k]) return 0.0;  // entirely outside one slab
    if (c[k] - r < b.lo[k] || c[k] + r > b.hi[k]) {
      ++cut_axes;
      cut_axis = k;
    }
  }
  if (cut_axes == 0) return 4.0 / 3.0 * kPi * r * r * r;
  if (cut_axes == 1) {
    const int k = cut_axis;
    return slab_volume(r, std::max(-r, b.lo[k] - c[k]), std::min(r, b.hi[k] - c[k]));
  }
  // Cut by faces of two or three axes: V = int_a^b A(t) dt over z-offsets t, with A(t) the area of
  // the disc of radius rho(t) = sqrt(r^2 - t^2) inside the x-y rectangle (disc_rectangle).
  // A changes form where rho equals the distance to an edge line or to a corner.
  const double x0 = b.lo.x() - c.x(), x1 = b.hi.x() - c.x();
  const double y0 = b.lo.y() - c.y(), y1 = b.hi.y() - c.y();
  const double a = std::max(-r, b.lo.z() - c.z()), e = std::min(r, b.hi.z() - c.z());
  std::vector<double> rho_breaks;
  for (double u : {x0, x1, y0, y1}) rho_breaks.push_back(std::abs(u));
  for (double u : {x0, x1})
    for (double v : {y0, y1}) rho_breaks.push_back(std::hypot(u, v));
  return integrate_slices(r, a, e, rho_breaks, [&](double rho) { return disc_rectangle(rho, x0, x1, y0, y1); });
}

/// Sphere (centre c, radius r) inside a finite cylinder.
double sphere_in_cylinder(const Vec3& c, double r, const CylinderRegion& cyl) {
  const Vec3 v = c - cyl.base;
  const double h = v.dot(cyl.axis);            // axial coordinate of the centre
  const double q = (v - h * cyl.axis).norm();  // distance of the centre from the axis
  const double big_r = cyl.radius;
  if (h + r <= 0.0 || h - r >= cyl.height || q - r >= big_r) return 0.0;
  const double a = std::max(-r, -h), b = std::min(r, cyl.height - h);  // axial offsets inside
  if (q + r <= big_r) return slab_volume(r, a, b);                     // clear of the curved wall
  // Cut by the curved wall: V = int_a^b lens(rho(t), R, q) dt, breakpoints where the slice
  // circle starts to cross the wall (rho = |R - q|) or contains the whole cross-section (rho = R + q).
  return integrate_slices(r, a, b, {std::abs(big_r - q), big_r + q}, [&](double rho) { return lens_area(rho, big_r, q); });
}

double sphere_in_region_unchecked(const Vec3& c, double r, const Region& region) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) return sphere_in_box(c, r, *b);
  return sphere_in_cylinder(c, r, std::get<CylinderRegion>(region));
}

bool contains_unchecked(const Region& region, const Vec3& p) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) return (p.array() >= b->lo.array()).all() && (p.array() <= b->hi.array()).all();
  const auto& cyl = std::get<CylinderRegion>(region);
  const Vec3 v = p - cyl.base;
  const double h = v.dot(cyl.axis);
  return h >= 0.0 && h <= cyl.height && (v - h * cyl.axis).norm() <= cyl.radius;
}

/// Shared coordination counter; `counted[i]` selects the particles entering the statistics.
CoordinationStats coordination_impl(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                                    const std::vector<std::array<Index, 2>>& pairs, double tol, const std::vector<bool>& counted) {
  if (!std::isfinite(tol) || tol < 0.0) throw ConfigError("", "relative gap tolerance must be >= 0 and finite, found " + format_number(tol, 12));
  const std::size_t n = positions.size();
  std::vector<int> z(n, 0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& p = pairs[k];
    check_pair(p, n, k);
    const auto i = static_cast<std::size_t>(p[0]), j = static_cast<std::size_t>(p[1]);
    if ((positions[i] - positions[j]).norm() <= (radii[i] + radii[j]) * (1.0 + tol)) {
      ++z[i];
      ++z[j];
    }
  }
  CoordinationStats s;
  std::size_t count = 0;
  long long total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!counted[i]) continue;
    ++count;
    total += z[i];
    if (static_cast<std::size_t>(z[i]) >= s.histogram.size()) s.histogram.resize(z[i] + 1, 0);
    ++s.histogram[z[i]];
    if (z[i] == 0) ++s.rattlers;
  }
  s.mean = count > 0 ? static_cast<double>(total) / static_cast<double>(count) : 0.0;
  return s;
}

}  // namespace

void validate(const Region& region) {
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    if (!b->lo.allFinite() || !b->hi.allFinite() || !(b->hi.array() > b->lo.array()).all())
      throw ConfigError("", "box region needs finite corners with hi > lo in every component");
    return;
  }
  const auto& c = std::get<CylinderRegion>(region);
  std::vector<Diagnostic> out;
  if (!c.base.allFinite()) out.push_back({"/base", "cylinder base must be finite"});
  if (!c.axis.allFinite() || std::abs(c.axis.norm() - 1.0) > 1e-6)
    out.push_back({"/axis", "cylinder axis must be a unit vector, |axis| = " + format_number(c.axis.norm(), 12)});
  if (!std::isfinite(c.radius) || c.radius <= 0.0)
    out.push_back({"/radius", "cylinder radius must be positive and finite [m], found " + format_number(c.radius, 12)});
  if (!std::isfinite(c.height) || c.height <= 0.0)
    out.push_back({"/height", "cylinder height must be positive and finite [m], found " + format_number(c.height, 12)});
  if (!out.empty()) throw ConfigError(std::move(out));
}

double region_volume(const Region& region) {
  validate(region);
  if (const auto* b = std::get_if<BoxRegion>(&region)) return (b->hi - b->lo).prod();
  const auto& c = std::get<CylinderRegion>(region);
  return kPi * c.radius * c.radius * c.height;
}

Region shrink(const Region& region, double margin) {
  validate(region);
  if (!std::isfinite(margin) || margin < 0.0) throw ConfigError("", "shrink margin must be >= 0 and finite [m], found " + format_number(margin, 12));
  Region out;
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    out = BoxRegion{(b->lo.array() + margin).matrix(), (b->hi.array() - margin).matrix()};
  } else {
    const auto& c = std::get<CylinderRegion>(region);
    out = CylinderRegion{c.base + margin * c.axis, c.axis, c.radius - margin, c.height - 2.0 * margin};
  }
  try {
    validate(out);
  } catch (const ConfigError&) { throw ConfigError("", "shrink margin " + format_number(margin, 12) + " m leaves an empty region"); }
  return out;
}

bool contains(const Region& region, const Vec3& point) {
  validate(region);
  return contains_unchecked(region, point);
}

double sphere_volume_in_region(const Vec3& centre, double radius, const Region& region) {
  validate(region);
  if (!centre.allFinite() || !std::isfinite(radius) || radius <= 0.0)
    throw ConfigError("", "sphere needs a finite centre and a positive finite radius, found r = " + format_number(radius, 12));
  return sphere_in_region_unchecked(centre, radius, region);
}

double solid_volume_in_region(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region) {
  validate(region);
  check_particles(positions, radii);
  double v = 0.0;
  for (std::size_t i = 0; i < positions.size(); ++i) v += sphere_in_region_unchecked(positions[i], radii[i], region);
  return v;
}

double packing_density(const std::vector<Vec3>& positions, const std::vector<double>& radii, const Region& region) {
  return solid_volume_in_region(positions, radii, region) / region_volume(region);
}

CoordinationStats coordination(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                               const std::vector<std::array<Index, 2>>& pairs, double gap_tolerance_relative) {
  check_particles(positions, radii);
  return coordination_impl(positions, radii, pairs, gap_tolerance_relative, std::vector<bool>(positions.size(), true));
}

CoordinationStats coordination_in_region(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                                         const std::vector<std::array<Index, 2>>& pairs, double gap_tolerance_relative, const Region& region) {
  check_particles(positions, radii);
  validate(region);
  std::vector<bool> counted(positions.size());
  for (std::size_t i = 0; i < positions.size(); ++i) counted[i] = contains_unchecked(region, positions[i]);
  return coordination_impl(positions, radii, pairs, gap_tolerance_relative, counted);
}

OverlapStats overlap_stats(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                           const std::vector<std::array<Index, 2>>& pairs) {
  check_particles(positions, radii);
  OverlapStats s;
  double sum = 0.0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const auto& p = pairs[k];
    check_pair(p, positions.size(), k);
    const auto i = static_cast<std::size_t>(p[0]), j = static_cast<std::size_t>(p[1]);
    // relative overlap delta / min(r_i, r_j), delta = r_i + r_j - |x_i - x_j|
    const double delta = radii[i] + radii[j] - (positions[i] - positions[j]).norm();
    if (delta <= 0.0) continue;
    const double rel = delta / std::min(radii[i], radii[j]);
    ++s.n_overlapping;
    sum += rel;
    if (rel > s.max_relative) {
      s.max_relative = rel;
      s.i = p[0];
      s.j = p[1];
    }
  }
  if (s.n_overlapping > 0) s.mean_relative = sum / static_cast<double>(s.n_overlapping);
  return s;
}

}  // namespace sparkdem::physics
