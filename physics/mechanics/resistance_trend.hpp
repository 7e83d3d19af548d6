#pragma once
/// # resistance_trend — crack onset as the first departure of R(theta) from its elastic trend
///
/// Seed 001 §4, Fig. 16 (../shared/physics/cohesive-joule-torsion.md §8 and §11; issue 58 item 5):
/// the resistance of a bonded pin follows an elastic trend while it is twisted, and leaves it when
/// bonds break; Fig. 16 shows R leaving its elastic line at about 0.043 rad, long before it has
/// risen by 1 %. The detector:
///
///   trend      u(x) = c0 + c1 x + c2 x^2, u = R/R0 - 1, x = theta / theta_fit, least squares
///              over the samples with |theta| <= theta_fit (the first part of the twist; a
///              sample is each new value of R, i.e. each re-solve of the network)
///   noise      sigma = sqrt(sum_k (u_k - u(x_k))^2 / (n - 3)), the fit's residual standard
///              deviation (n >= kMinSamples, otherwise no trend and no onset)
///   departure  d = (u - u(x)) / (k sigma + eps), k = `sigmas`, eps = `floor` (the network
///              solver's relative tolerance on R); the onset is the first twist past theta_fit
///              where |d| > 1 holds persistently (the caller's persistence filter). Both signs:
///              in seed 001's network a broken bond can lower R, because S_i = alpha(n_i) r_i^2
///              grows as n_i falls (alpha(3) = 13.6 against alpha(6) = 4), widening the element's
///              remaining branches (calibration seed 102 at N = 5000: the first break moves R by
///              -6.2e-5, the next ones raise it)
///
/// The quadratic term carries the elastic drift of R: the beams' lengths change at first order
/// in the shear with both signs, so the mean change is of second order in theta. u and x are
/// scaled to O(1e-3) and O(1) before the normal equations (no cancellation of 1 + small numbers).
/// All the state is the sums below: the caller keeps them in State::marks (checkpointed).
#include <array>
#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace sparkdem::physics::trend {

inline constexpr double kMinSamples = 6.0;

/// Normal-equation sums of the quadratic fit: n, sum x^p (p = 0..4), sum x^p u (p = 0..2), sum u^2.
struct Sums {
  std::array<double, 5> xp{};  ///< sum x^p, p = 0..4 (xp[0] = n)
  std::array<double, 3> xu{};  ///< sum x^p u, p = 0..2
  double uu = 0.0;             ///< sum u^2

  void add(double x, double u) {
    double xk = 1.0;
    for (std::size_t p = 0; p < 5; ++p) {
      xp[p] += xk;
      if (p < 3) xu[p] += xk * u;
      xk *= x;
    }
    uu += u * u;
  }
  double n() const { return xp[0]; }
};

struct Fit {
  Eigen::Vector3d c = Eigen::Vector3d::Zero();  ///< u(x) = c0 + c1 x + c2 x^2
  double sigma = std::numeric_limits<double>::quiet_NaN();
  bool valid = false;
};

/// The least-squares quadratic and its residual standard deviation (valid only with n >= kMinSamples
/// and a non-singular system: samples at three distinct x or more).
inline Fit fit(const Sums& s) {
  Fit f;
  if (s.n() < kMinSamples) return f;
  Eigen::Matrix3d A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = s.xp[static_cast<std::size_t>(i + j)];
  const Eigen::Vector3d b(s.xu[0], s.xu[1], s.xu[2]);
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (lu.rank() < 3) return f;
  f.c = lu.solve(b);
  // Residual sum of squares at the normal equations' solution: sum u^2 - c . b.
  const double rss = std::max(0.0, s.uu - f.c.dot(b));
  f.sigma = std::sqrt(rss / (s.n() - 3.0));
  f.valid = true;
  return f;
}

/// The departure d = (u - u(x)) / (sigmas sigma + floor) of a sample (x, u) from the trend; NaN
/// without a valid fit; +inf for u = +inf (no path: separated).
inline double departure(const Fit& f, double x, double u, double sigmas, double floor) {
  if (!f.valid) return std::numeric_limits<double>::quiet_NaN();
  if (std::isinf(u)) return u;
  const double trend = f.c[0] + x * (f.c[1] + x * f.c[2]);
  return (u - trend) / (sigmas * f.sigma + floor);
}

}  // namespace sparkdem::physics::trend
