#include "physics/packing/size_distribution.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>
#include "engine/core/numbers.hpp"
#include "engine/core/format.hpp"

namespace sparkdem::physics {
namespace {

constexpr double kFractionTolerance = 1e-6;  ///< allowed |F_last - 1| and overshoot of F_k above 1


/// Standard normal CDF Phi(z) = erfc(-z / sqrt 2) / 2 (accurate in the lower tail).
double phi_cdf(double z) { return 0.5 * std::erfc(-z / std::numbers::sqrt2); }
/// Standard normal survival Q(z) = 1 - Phi(z) = erfc(z / sqrt 2) / 2 (accurate in the upper tail).
double phi_sf(double z) { return 0.5 * std::erfc(z / std::numbers::sqrt2); }

/// Inverse standard normal CDF z = Phi^-1(p) for p in (0, 0.5]: Acklam's rational
/// approximation (relative error < 1.2e-9) followed by one Halley step on Phi(z) - p = 0,
///   e = Phi(z) - p,  u = e sqrt(2 pi) exp(z^2 / 2),  z <- z - u / (1 + z u / 2),
/// which brings it to about full double precision.
double inverse_phi_lower(double p) {
  static constexpr double a[] = {-3.969683028665376e+01, 2.209460984245205e+02,  -2.759285104469687e+02,
                                 1.383577518672690e+02,  -3.066479806614716e+01, 2.506628277459239e+00};
  static constexpr double b[] = {-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02, 6.680131188771972e+01,
                                 -1.328068155288572e+01};
  static constexpr double c[] = {-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
                                 -2.549732539343734e+00, 4.374664141464968e+00,  2.938163982698783e+00};
  static constexpr double d[] = {7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00, 3.754408661907416e+00};
  double z;
  if (p < 0.02425) {
    const double q = std::sqrt(-2.0 * std::log(p));
    z = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1.0);
  } else {
    const double q = p - 0.5;
    const double r = q * q;
    z = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q /
        (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1.0);
  }
  const double e = phi_cdf(z) - p;
  const double u = e * std::sqrt(2.0 * std::numbers::pi) * std::exp(0.5 * z * z);
  return z - u / (1.0 + 0.5 * z * u);
}

/// Phi^-1(p) on [0, 1], using Phi^-1(p) = -Phi^-1(1 - p) above 1/2 (1 - p is exact there).
double inverse_phi(double p) {
  if (p <= 0.0) return -kInf;
  if (p >= 1.0) return kInf;
  return p <= 0.5 ? inverse_phi_lower(p) : -inverse_phi_lower(1.0 - p);
}

/// A validated distribution reduced to what the number CDF, its inverse and its mean need.
struct Prepared {
  SizeDistributionKind kind;
  // table: node diameters and NUMBER CDF at the nodes, N_0 = point mass at d_0, N_{K-1} = 1
  std::vector<double> d, n;
  bool volume = false;
  // lognormal: mu = ln d50, standardised truncation bounds, mass inside them; `upper` = work
  // with survival probabilities (bounds in the upper tail, where Phi rounds to 1)
  double mu = 0, sigma = 1, z_lo = -kInf, z_hi = kInf, mass = 1;
  bool upper = false;
  // uniform bounds [m]
  double lo = 0, hi = 0;
};

/// Number CDF of a volume-basis table. With the volume CDF G piecewise linear, the volume
/// density on (d_k, d_{k+1}) is g_k = (G_{k+1} - G_k) / (d_{k+1} - d_k) and the number density is
/// proportional to g_k / d^3, which integrates in closed form (no sub-grid quadrature needed):
///   w_k = integral_{d_k}^{d_{k+1}} g_k / x^3 dx = g_k (d_k^-2 - d_{k+1}^-2) / 2
///       = (G_{k+1} - G_k) (d_k + d_{k+1}) / (2 d_k^2 d_{k+1}^2),
/// and the point mass G_0 at d_0 holds w_0 = G_0 / d_0^3 particles (same proportionality,
/// particle volume pi/6 d^3). N at the nodes = cumulative w / total w. Inside an interval
///   N(d) = N_k + (N_{k+1} - N_k) (d_k^-2 - d^-2) / (d_k^-2 - d_{k+1}^-2).
/// Diameters are scaled by d_0 (x = d / d_0) to keep the powers in range.
std::vector<double> volume_to_number_nodes(const std::vector<double>& d, const std::vector<double>& g) {
  const std::size_t k_count = d.size();
  std::vector<double> n(k_count);
  double acc = g[0];  // w_0 = G_0 / x_0^3 with x_0 = 1
  n[0] = acc;
  for (std::size_t k = 0; k + 1 < k_count; ++k) {
    const double x0 = d[k] / d[0], x1 = d[k + 1] / d[0];
    acc += (g[k + 1] - g[k]) * (x0 + x1) / (2.0 * x0 * x0 * x1 * x1);
    n[k + 1] = acc;
  }
  for (double& v : n) v /= acc;
  return n;
}

Prepared prepare(const SizeDistribution& s) {
  validate(s);
  Prepared p;
  p.kind = s.kind;
  switch (s.kind) {
    case SizeDistributionKind::table: {
      p.d = s.diameters;
      std::vector<double> f = s.cumulative_fraction;
      const double last = f.back();
      for (double& v : f) v = std::min(v / last, 1.0);  // last within 1e-6 of 1: make it exactly 1
      p.volume = s.basis == SizeBasis::volume;
      p.n = p.volume ? volume_to_number_nodes(p.d, f) : f;
      p.n.back() = 1.0;
      break;
    }
    case SizeDistributionKind::lognormal: {
      p.mu = std::log(s.d50);
      p.sigma = s.sigma;
      p.z_lo = s.d_min > 0.0 ? (std::log(s.d_min) - p.mu) / p.sigma : -kInf;
      p.z_hi = std::isfinite(s.d_max) ? (std::log(s.d_max) - p.mu) / p.sigma : kInf;
      p.upper = p.z_lo > 0.0;
      p.mass = p.upper ? phi_sf(p.z_lo) - phi_sf(p.z_hi) : phi_cdf(p.z_hi) - phi_cdf(p.z_lo);
      p.lo = s.d_min;
      p.hi = s.d_max;
      break;
    }
    case SizeDistributionKind::uniform:
      p.lo = s.d_min;
      p.hi = s.d_max;
      break;
  }
  return p;
}

/// Number CDF N(d); `left` gives the left limit N(d-) (differs from N(d) only at a point mass).
double cdf(const Prepared& p, double d, bool left) {
  switch (p.kind) {
    case SizeDistributionKind::table: {
      if (d < p.d.front() || (left && d == p.d.front())) return 0.0;
      if (d >= p.d.back()) return 1.0;
      const std::size_t k = static_cast<std::size_t>(std::upper_bound(p.d.begin(), p.d.end(), d) - p.d.begin()) - 1;
      const double d0 = p.d[k], d1 = p.d[k + 1];
      const double s = p.volume ? (1.0 / (d0 * d0) - 1.0 / (d * d)) / (1.0 / (d0 * d0) - 1.0 / (d1 * d1)) : (d - d0) / (d1 - d0);
      return p.n[k] + (p.n[k + 1] - p.n[k]) * std::clamp(s, 0.0, 1.0);
    }
    case SizeDistributionKind::lognormal: {
      if (d <= 0.0) return 0.0;
      const double z = std::clamp((std::log(d) - p.mu) / p.sigma, p.z_lo, p.z_hi);
      const double f = p.upper ? (phi_sf(p.z_lo) - phi_sf(z)) / p.mass : (phi_cdf(z) - phi_cdf(p.z_lo)) / p.mass;
      return std::clamp(f, 0.0, 1.0);
    }
    case SizeDistributionKind::uniform:
      if (d < p.lo || (left && d == p.lo)) return 0.0;
      if (d >= p.hi) return 1.0;
      return (d - p.lo) / (p.hi - p.lo);
  }
  return 0.0;
}

/// Number quantile N^-1(u), u in [0, 1].
double quantile(const Prepared& p, double u) {
  switch (p.kind) {
    case SizeDistributionKind::table: {
      // first node with N_k >= u; k = 0 is the point mass at d_0, otherwise N_{k-1} < u <= N_k
      const std::size_t k = static_cast<std::size_t>(std::lower_bound(p.n.begin(), p.n.end(), u) - p.n.begin());
      if (k == 0) return p.d.front();
      if (k >= p.n.size()) return p.d.back();
      const double d0 = p.d[k - 1], d1 = p.d[k];
      const double t = (u - p.n[k - 1]) / (p.n[k] - p.n[k - 1]);
      double d;
      if (p.volume) {
        // d^-2 = d_{k-1}^-2 - t (d_{k-1}^-2 - d_k^-2)
        const double inv0 = 1.0 / (d0 * d0), inv1 = 1.0 / (d1 * d1);
        d = 1.0 / std::sqrt(inv0 - t * (inv0 - inv1));
      } else {
        d = d0 + t * (d1 - d0);
      }
      return std::clamp(d, d0, d1);
    }
    case SizeDistributionKind::lognormal: {
      // truncated inverse CDF: Phi(z) = Phi(z_lo) + u mass  (or, in the upper tail,
      // Q(z) = Q(z_lo) - u mass with z = -Phi^-1(Q))
      const double z = p.upper ? -inverse_phi(phi_sf(p.z_lo) - u * p.mass) : inverse_phi(phi_cdf(p.z_lo) + u * p.mass);
      return std::clamp(std::exp(p.mu + p.sigma * z), p.lo, p.hi);
    }
    case SizeDistributionKind::uniform:
      return p.lo + u * (p.hi - p.lo);
  }
  return 0.0;
}

/// Number-mean diameter:
///   table, number basis: sum_k (N_{k+1} - N_k) (d_k + d_{k+1}) / 2  + N_0 d_0
///   table, volume basis: number density ~ d^-3 on each interval, whose mean is
///       int d^-2 / int d^-3 = 2 / (1/d_k + 1/d_{k+1})  (harmonic mean of the ends)
///   lognormal truncated to [z_lo, z_hi] (standardised):
///       d50 exp(sigma^2 / 2) [Phi(z_hi - sigma) - Phi(z_lo - sigma)] / [Phi(z_hi) - Phi(z_lo)]
///   uniform: (d_min + d_max) / 2
double mean(const Prepared& p) {
  switch (p.kind) {
    case SizeDistributionKind::table: {
      double m = p.n[0] * p.d[0];
      for (std::size_t k = 0; k + 1 < p.d.size(); ++k) {
        const double d0 = p.d[k], d1 = p.d[k + 1];
        const double interval_mean = p.volume ? 2.0 / (1.0 / d0 + 1.0 / d1) : 0.5 * (d0 + d1);
        m += (p.n[k + 1] - p.n[k]) * interval_mean;
      }
      return m;
    }
    case SizeDistributionKind::lognormal: {
      const double s = p.sigma;
      const double ratio = p.upper ? (phi_sf(p.z_lo - s) - phi_sf(p.z_hi - s)) / p.mass
                                   : (phi_cdf(p.z_hi - s) - phi_cdf(p.z_lo - s)) / p.mass;
      return std::exp(p.mu + 0.5 * s * s) * ratio;
    }
    case SizeDistributionKind::uniform:
      return 0.5 * (p.lo + p.hi);
  }
  return 0.0;
}

void validate_table(const SizeDistribution& s, std::vector<Diagnostic>& out) {
  const auto& d = s.diameters;
  const auto& f = s.cumulative_fraction;
  if (d.empty()) out.push_back({"/diameters", "needs at least one point"});
  if (f.size() != d.size())
    out.push_back({"/cumulative_fraction", "has " + std::to_string(f.size()) + " values but /diameters has " + std::to_string(d.size())});
  for (std::size_t k = 0; k < d.size(); ++k) {
    const std::string path = "/diameters/" + std::to_string(k);
    if (!std::isfinite(d[k]) || d[k] <= 0.0)
      out.push_back({path, "diameter must be positive and finite [m], found " + format_number(d[k], 12)});
    else if (k > 0 && std::isfinite(d[k - 1]) && d[k] <= d[k - 1])
      out.push_back({path, "diameters must be strictly increasing, found " + format_number(d[k], 12) + " after " + format_number(d[k - 1], 12)});
  }
  for (std::size_t k = 0; k < f.size(); ++k) {
    const std::string path = "/cumulative_fraction/" + std::to_string(k);
    if (!std::isfinite(f[k]) || f[k] < 0.0 || f[k] > 1.0 + kFractionTolerance)
      out.push_back({path, "cumulative fraction must be in [0, 1], found " + format_number(f[k], 12)});
    else if (k > 0 && std::isfinite(f[k - 1]) && f[k] < f[k - 1])
      out.push_back({path, "cumulative fractions must be non-decreasing, found " + format_number(f[k], 12) + " after " + format_number(f[k - 1], 12)});
  }
  if (!f.empty() && !(std::abs(f.back() - 1.0) <= kFractionTolerance))
    out.push_back({"/cumulative_fraction", "fractions must add up to 1: last cumulative fraction is " + format_number(f.back(), 12) + " (tolerance 1e-6)"});
}

void validate_lognormal(const SizeDistribution& s, std::vector<Diagnostic>& out) {
  const std::size_t before = out.size();
  if (!std::isfinite(s.d50) || s.d50 <= 0.0)
    out.push_back({"/d50", "median diameter must be positive and finite [m], found " + format_number(s.d50, 12)});
  if (!std::isfinite(s.sigma) || s.sigma <= 0.0)
    out.push_back({"/sigma", "sigma of ln d must be positive and finite, found " + format_number(s.sigma, 12)});
  if (!std::isfinite(s.d_min) || s.d_min < 0.0)
    out.push_back({"/d_min", "lower truncation must be >= 0 and finite [m] (0 = none), found " + format_number(s.d_min, 12)});
  if (std::isnan(s.d_max) || s.d_max <= 0.0)
    out.push_back({"/d_max", "upper truncation must be positive [m] (infinite = none), found " + format_number(s.d_max, 12)});
  else if (std::isfinite(s.d_min) && s.d_min >= s.d_max)
    out.push_back({"/d_max", "d_min (" + format_number(s.d_min, 12) + ") must be smaller than d_max (" + format_number(s.d_max, 12) + ")"});
  if (out.size() != before) return;
  // the truncation interval must hold a representable probability
  const double mu = std::log(s.d50);
  const double z_lo = s.d_min > 0.0 ? (std::log(s.d_min) - mu) / s.sigma : -kInf;
  const double z_hi = std::isfinite(s.d_max) ? (std::log(s.d_max) - mu) / s.sigma : kInf;
  const double mass = z_lo > 0.0 ? phi_sf(z_lo) - phi_sf(z_hi) : phi_cdf(z_hi) - phi_cdf(z_lo);
  if (!(mass > 0.0))
    out.push_back({"/d_min", "truncation interval [" + format_number(s.d_min, 12) + ", " + format_number(s.d_max, 12) +
                                 "] holds no probability for d50 = " + format_number(s.d50, 12) + ", sigma = " + format_number(s.sigma, 12)});
}

void validate_uniform(const SizeDistribution& s, std::vector<Diagnostic>& out) {
  const bool lo_ok = std::isfinite(s.d_min) && s.d_min > 0.0;
  const bool hi_ok = std::isfinite(s.d_max) && s.d_max > 0.0;
  if (!lo_ok) out.push_back({"/d_min", "diameter must be positive and finite [m], found " + format_number(s.d_min, 12)});
  if (!hi_ok) out.push_back({"/d_max", "diameter must be positive and finite [m], found " + format_number(s.d_max, 12)});
  if (lo_ok && hi_ok && s.d_min > s.d_max)
    out.push_back({"/d_max", "d_min (" + format_number(s.d_min, 12) + ") must not exceed d_max (" + format_number(s.d_max, 12) + ")"});
}

}  // namespace

SizeDistribution make_table(std::vector<double> diameters, std::vector<double> cumulative_fraction, SizeBasis basis) {
  SizeDistribution s;
  s.kind = SizeDistributionKind::table;
  s.diameters = std::move(diameters);
  s.cumulative_fraction = std::move(cumulative_fraction);
  s.basis = basis;
  validate(s);
  return s;
}

SizeDistribution make_lognormal(double d50, double sigma, double d_min, double d_max) {
  SizeDistribution s;
  s.kind = SizeDistributionKind::lognormal;
  s.d50 = d50;
  s.sigma = sigma;
  s.d_min = d_min;
  s.d_max = d_max;
  validate(s);
  return s;
}

SizeDistribution make_uniform(double d_min, double d_max) {
  SizeDistribution s;
  s.kind = SizeDistributionKind::uniform;
  s.d_min = d_min;
  s.d_max = d_max;
  validate(s);
  return s;
}

SizeDistribution uniform_about_mean(double r_mean, double spread) {
  std::vector<Diagnostic> out;
  if (!std::isfinite(r_mean) || r_mean <= 0.0)
    out.push_back({"/r_mean", "mean radius must be positive and finite [m], found " + format_number(r_mean, 12)});
  if (!std::isfinite(spread) || spread < 0.0 || spread >= 1.0)
    out.push_back({"/spread", "relative spread must be in [0, 1), found " + format_number(spread, 12)});
  if (!out.empty()) throw ConfigError(std::move(out));
  return make_uniform(2.0 * r_mean * (1.0 - spread), 2.0 * r_mean * (1.0 + spread));
}

void validate(const SizeDistribution& dist) {
  std::vector<Diagnostic> out;
  switch (dist.kind) {
    case SizeDistributionKind::table:
      validate_table(dist, out);
      break;
    case SizeDistributionKind::lognormal:
      validate_lognormal(dist, out);
      break;
    case SizeDistributionKind::uniform:
      validate_uniform(dist, out);
      break;
    default:
      out.push_back({"/kind", "unknown size distribution kind"});
      break;
  }
  if (!out.empty()) throw ConfigError(std::move(out));
}

double cdf_number(const SizeDistribution& dist, double d) { return cdf(prepare(dist), d, false); }

double quantile_number(const SizeDistribution& dist, double p) {
  if (!(p >= 0.0 && p <= 1.0)) throw ConfigError("", "quantile probability must be in [0, 1], found " + format_number(p, 12));
  return quantile(prepare(dist), p);
}

double mean_diameter_number(const SizeDistribution& dist) { return mean(prepare(dist)); }

double uniform_open01(std::mt19937_64& rng) {
  constexpr double two_pow_minus_53 = 1.0 / 9007199254740992.0;
  return (static_cast<double>(rng() >> 11) + 0.5) * two_pow_minus_53;
}

double sample_diameter(const SizeDistribution& dist, std::mt19937_64& rng) { return quantile(prepare(dist), uniform_open01(rng)); }

std::vector<double> sample_until_volume(const SizeDistribution& dist, double solid_volume_m3, std::mt19937_64& rng, std::size_t max_count) {
  if (!std::isfinite(solid_volume_m3) || solid_volume_m3 < 0.0)
    throw ConfigError("", "solid volume must be >= 0 and finite [m^3], found " + format_number(solid_volume_m3, 12));
  const Prepared p = prepare(dist);
  std::vector<double> out;
  double total = 0.0;
  while (total < solid_volume_m3) {
    const double d = quantile(p, uniform_open01(rng));
    const double v = std::numbers::pi / 6.0 * d * d * d;
    if (total + v > solid_volume_m3) {
      // crossing draw: keep it if |total + v - target| < |target - total|
      if (total + v - solid_volume_m3 < solid_volume_m3 - total) out.push_back(d);
      break;
    }
    if (out.size() >= max_count)
      throw SetupError("size distribution needs more than " + std::to_string(max_count) + " particles to reach a solid volume of " +
                       format_number(solid_volume_m3, 12) + " m^3");
    out.push_back(d);
    total += v;
  }
  return out;
}

DistributionReport compare(const SizeDistribution& dist, const std::vector<double>& sampled_diameters) {
  const Prepared p = prepare(dist);
  if (sampled_diameters.empty()) throw ConfigError("", "no sampled diameters to compare");
  for (std::size_t i = 0; i < sampled_diameters.size(); ++i)
    if (!std::isfinite(sampled_diameters[i]) || sampled_diameters[i] <= 0.0)
      throw ConfigError("/" + std::to_string(i), "sampled diameter must be positive and finite [m], found " + format_number(sampled_diameters[i], 12));
  std::vector<double> x = sampled_diameters;
  std::sort(x.begin(), x.end());
  const std::size_t n = x.size();
  const double dn = static_cast<double>(n);

  DistributionReport r;
  r.n = n;
  r.quantiles = {0.1, 0.5, 0.9};
  for (double q : r.quantiles) {
    r.requested_d.push_back(quantile(p, q));
    // smallest sample x_(k) (1-based k) with k / n >= q; the 1e-12 guards q n rounding up
    const double k = std::ceil(q * dn * (1.0 - 1e-12));
    const std::size_t idx = std::min(n - 1, static_cast<std::size_t>(std::max(k, 1.0)) - 1);
    r.sampled_d.push_back(x[idx]);
  }

  // Kolmogorov-Smirnov: F_n is a step function, N non-decreasing, so the supremum of |F_n - N| is
  // reached at a sample value x: compare N(x) with F_n(x) and N(x-) with F_n(x-). Equal samples
  // (point masses) form one step.
  double ks = 0.0;
  for (std::size_t a = 0; a < n;) {
    std::size_t b = a;
    while (b < n && x[b] == x[a]) ++b;
    ks = std::max(ks, std::abs(static_cast<double>(b) / dn - cdf(p, x[a], false)));
    ks = std::max(ks, std::abs(static_cast<double>(a) / dn - cdf(p, x[a], true)));
    a = b;
  }
  r.ks_distance = ks;

  double s1 = 0.0, s3 = 0.0, s4 = 0.0;
  for (double d : x) {
    s1 += d;
    s3 += d * d * d;
    s4 += d * d * d * d;
  }
  r.mean_d_requested = mean(p);
  r.mean_d_sampled = s1 / dn;
  r.volume_mean_d_sampled = s4 / s3;
  return r;
}

}  // namespace sparkdem::physics
