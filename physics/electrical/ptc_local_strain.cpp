#include "physics/electrical/ptc_local_strain.hpp"

#include <string>

#include "engine/core/error.hpp"

namespace sparkdem::physics::ptc {

void LocalStrainSolver::factorize(std::size_t n, const SpringNetwork& net, const MatrixParams& p) {
  if (!(p.regularisation >= 0.0)) throw SetupError("ptc_local_strain: regularisation must be >= 0");
  n_ = n;
  net_ = net;
  const std::int64_t m = 3 * static_cast<std::int64_t>(n);
  double kmean = 0.0;
  for (double k : net.stiffness) kmean += k;
  kmean = net.size() ? kmean / static_cast<double>(net.size()) : 1.0;
  const double ground = p.regularisation * kmean;  // as ptc::solve_unit
  std::vector<Eigen::Triplet<double>> t;
  t.reserve(36 * net.size() + static_cast<std::size_t>(m));
  for (std::size_t e = 0; e < net.size(); ++e) {
    const Vec3& nn = net.normal[e];
    const double k = net.stiffness[e];
    const std::int64_t d[2] = {3 * static_cast<std::int64_t>(net.a[e]), 3 * static_cast<std::int64_t>(net.b[e])};
    const double sign[2] = {-1.0, 1.0};  // B u = n . (u_b - u_a)
    for (int s = 0; s < 2; ++s)
      for (int q = 0; q < 2; ++q)
        for (int c = 0; c < 3; ++c)
          for (int r = 0; r < 3; ++r) t.emplace_back(d[s] + c, d[q] + r, k * sign[s] * sign[q] * nn[c] * nn[r]);
  }
  for (std::int64_t i = 0; i < m; ++i) t.emplace_back(i, i, ground);
  K_.resize(m, m);
  K_.setFromTriplets(t.begin(), t.end());
  ready_ = false;
  if (m == 0) {
    ready_ = true;
    return;
  }
  ldlt_.compute(K_);
  if (ldlt_.info() != Eigen::Success)
    throw SetupError("ptc_local_strain: the spring-network matrix could not be factorised (singular: raise regularisation)");
  ready_ = true;
}

void LocalStrainSolver::solve(std::span<const double> eps0_spring, std::vector<Vec3>& displacement, std::vector<double>& opening) const {
  if (!ready_) throw SetupError("ptc_local_strain: solve() before factorize()");
  if (eps0_spring.size() != net_.size())
    throw SetupError("ptc_local_strain: expected " + std::to_string(net_.size()) + " spring strains, found " +
                     std::to_string(eps0_spring.size()));
  displacement.assign(n_, Vec3::Zero());
  opening.assign(net_.size(), 0.0);
  if (n_ == 0) return;
  Eigen::VectorXd f = Eigen::VectorXd::Zero(3 * static_cast<Eigen::Index>(n_));
  for (std::size_t e = 0; e < net_.size(); ++e) {
    const double w = net_.stiffness[e] * net_.eigen_gap[e] * eps0_spring[e];
    if (w == 0.0) continue;
    for (int c = 0; c < 3; ++c) {
      f[3 * net_.a[e] + c] -= w * net_.normal[e][c];
      f[3 * net_.b[e] + c] += w * net_.normal[e][c];
    }
  }
  const Eigen::VectorXd u = ldlt_.solve(f);
  for (std::size_t i = 0; i < n_; ++i) displacement[i] = Vec3(u[3 * i], u[3 * i + 1], u[3 * i + 2]);
  for (std::size_t e = 0; e < net_.size(); ++e) opening[e] = net_.normal[e].dot(displacement[net_.b[e]] - displacement[net_.a[e]]);
}

}  // namespace sparkdem::physics::ptc
