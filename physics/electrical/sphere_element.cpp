#include "physics/electrical/sphere_element.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "physics/electrical/conductance_kernels.hpp"

namespace sparkdem::physics::electrical {

namespace {

/// beta_l(alpha) for l = 1..L (index l): the mean of P_l over a cap of half-angle alpha.
/// 1 - cos(alpha) is taken as 2 sin^2(alpha/2) so that small caps keep their digits.
void cap_means(double alpha, int L, std::vector<double>& beta) {
  const double c = std::cos(alpha), one_minus_c = 2.0 * std::sin(0.5 * alpha) * std::sin(0.5 * alpha);
  beta.assign(static_cast<std::size_t>(L) + 1, 0.0);
  // P_{l-1}(c) - P_{l+1}(c) with the three-term recurrence; P_0 - P_2 at l = 1.
  double pm1 = 1.0, p0 = c;  // P_{l-1}, P_l at l = 1
  for (int l = 1; l <= L; ++l) {
    const double p1 = ((2.0 * l + 1.0) * c * p0 - l * pm1) / (l + 1.0);  // P_{l+1}
    // P_{l-1} - P_{l+1} loses digits when both are near 1; (1 - c) is exact, and the difference
    // is (2l+1)(1-c) beta_l with |beta_l| <= 1, so the absolute error ~1e-16 is harmless for
    // alpha >= 1e-4 (l_cap bounds the caps the element resolves anyway).
    beta[static_cast<std::size_t>(l)] = (pm1 - p1) / ((2.0 * l + 1.0) * one_minus_c);
    pm1 = p0;
    p0 = p1;
  }
}

}  // namespace

double cap_half_angle(double a_m, double R_m, CapRule rule) {
  detail::require_nonnegative("neck radius a [m]", a_m);
  detail::require_positive("sphere radius R [m]", R_m);
  const double x = std::min(a_m / R_m, 1.0);
  return rule == CapRule::EqualArea ? 2.0 * std::asin(0.5 * x) : std::asin(x);
}

Eigen::MatrixXd sphere_patch_resistance(double kappa_S_per_m, double R_m, std::span<const Vec3> u, std::span<const double> alpha_rad,
                                        const SphereElementOptions& o) {
  detail::require_positive("conductivity kappa [S/m]", kappa_S_per_m);
  detail::require_positive("sphere radius R [m]", R_m);
  if (u.size() != alpha_rad.size())
    detail::invalid("patch angles (one per direction), count", "equal to the directions", static_cast<double>(alpha_rad.size()));
  if (!(o.l_per_radian > 0.0) || o.l_min < 1 || o.l_cap < o.l_min)
    detail::invalid("sphere element truncation l_per_radian", "> 0 with 1 <= l_min <= l_cap", o.l_per_radian);
  const std::size_t n = u.size();
  double alpha_min = kPi;
  for (double a : alpha_rad) {
    if (!(a > 0.0 && a <= 0.5 * kPi + 1e-12)) detail::invalid("cap half-angle alpha [rad]", "in (0, pi/2]", a);
    alpha_min = std::min(alpha_min, a);
  }
  const int L = static_cast<int>(
      std::clamp(std::ceil(o.l_per_radian / alpha_min), static_cast<double>(o.l_min), static_cast<double>(o.l_cap)));
  std::vector<std::vector<double>> beta(n);
  for (std::size_t p = 0; p < n; ++p) cap_means(alpha_rad[p], L, beta[p]);
  std::vector<double> w(static_cast<std::size_t>(L) + 1, 0.0);
  for (int l = 1; l <= L; ++l) w[static_cast<std::size_t>(l)] = (2.0 * l + 1.0) / l;
  Eigen::MatrixXd H(n, n);
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t q = p; q < n; ++q) {
      const double x = std::clamp(u[p].dot(u[q]), -1.0, 1.0);
      double pm1 = 1.0, p0 = x, sum = 0.0;
      for (int l = 1; l <= L; ++l) {
        const auto k = static_cast<std::size_t>(l);
        sum += w[k] * beta[p][k] * beta[q][k] * p0;
        const double p1 = ((2.0 * l + 1.0) * x * p0 - l * pm1) / (l + 1.0);
        pm1 = p0;
        p0 = p1;
      }
      H(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) = H(static_cast<Eigen::Index>(q), static_cast<Eigen::Index>(p)) = sum;
    }
  return H / (4.0 * kPi * kappa_S_per_m * R_m);
}

Eigen::MatrixXd sphere_patch_conductance(double kappa_S_per_m, double R_m, std::span<const Vec3> u, std::span<const double> alpha_rad,
                                         const SphereElementOptions& o) {
  const auto n = static_cast<Eigen::Index>(u.size());
  if (n < 2) {
    if (n == 1) (void)sphere_patch_resistance(kappa_S_per_m, R_m, u, alpha_rad, o);  // validate the arguments
    return Eigen::MatrixXd::Zero(n, n);
  }
  const Eigen::MatrixXd H = sphere_patch_resistance(kappa_S_per_m, R_m, u, alpha_rad, o);
  // Q: the last n-1 columns of the Householder reflection that maps 1/sqrt(n) to e_1.
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(n);
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(ones);
  const Eigen::MatrixXd Qfull = qr.householderQ() * Eigen::MatrixXd::Identity(n, n);
  const Eigen::MatrixXd Q = Qfull.rightCols(n - 1);
  const Eigen::MatrixXd Hr = Q.transpose() * H * Q;
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Hr);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive())
    detail::invalid("sphere element: the patch resistance kernel on zero-sum currents, smallest pivot", "> 0 (distinct patch directions)",
                    ldlt.vectorD().minCoeff());
  Eigen::MatrixXd K = Q * ldlt.solve(Q.transpose());
  K = 0.5 * (K + K.transpose());
  return K;
}

}  // namespace sparkdem::physics::electrical
