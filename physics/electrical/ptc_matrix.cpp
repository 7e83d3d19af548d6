#include "physics/electrical/ptc_matrix.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/electrical/contact_percolation.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics::ptc {

namespace {
}

SpringNetwork build_network(const std::vector<Vec3>& x, const std::vector<double>& r, const MatrixParams& p) {
  if (x.size() != r.size()) throw SetupError("ptc_matrix: positions and radii differ in length");
  if (!(p.min_gap_rel > 0.0)) throw SetupError("ptc_matrix: min_gap_rel (h_min / D) must be > 0");
  if (!(p.cutoff_gap_rel >= p.touch_gap_rel))
    throw SetupError("ptc_matrix: cutoff_gap_rel must be >= touch_gap_rel (touching pairs need springs)");
  if (!(p.matrix_modulus > 0.0) || !(p.bond_area > 0.0)) throw SetupError("ptc_matrix: matrix_modulus and bond_area must be > 0");
  SpringNetwork net;
  if (x.empty()) return net;
  // find_pairs returns d < r_i + r_j + skin: a skin slightly above the largest h_max keeps
  // gap == h_max; each pair is then cut at its own h_max = cutoff_gap_rel (R_i + R_j).
  const double r_max = *std::max_element(r.begin(), r.end());
  auto pairs = find_pairs(x, r, 2.0 * r_max * p.cutoff_gap_rel * (1.0 + 1e-12) + 1e-300);
  for (auto& pr : pairs)
    if (pr[0] > pr[1]) std::swap(pr[0], pr[1]);
  std::sort(pairs.begin(), pairs.end());
  for (const auto& pr : pairs) {
    const Vec3 d = x[pr[1]] - x[pr[0]];
    const double dist = d.norm();
    if (!(dist > 0.0))
      throw SetupError("ptc_matrix: fillers " + std::to_string(pr[0]) + " and " + std::to_string(pr[1]) + " have coincident centres");
    const double D = r[pr[0]] + r[pr[1]], h = dist - D;
    if (h > p.cutoff_gap_rel * D) continue;
    net.a.push_back(pr[0]);
    net.b.push_back(pr[1]);
    net.gap.push_back(h);
    net.normal.push_back(d / dist);
    net.stiffness.push_back(p.matrix_modulus * p.bond_area / std::max(h, p.min_gap_rel * D));
    net.eigen_gap.push_back(h > p.touch_gap_rel * D ? h : 0.0);
    net.distance.push_back(D);
  }
  return net;
}

UnitSolution solve_unit(std::size_t n, const SpringNetwork& net, const MatrixParams& p, std::span<const Index> fixed) {
  UnitSolution out;
  out.displacement.assign(n, Vec3::Zero());
  out.opening.assign(net.size(), 0.0);
  if (n == 0) return out;
  if (!(p.regularisation >= 0.0)) throw SetupError("ptc_matrix: regularisation must be >= 0");
  std::vector<char> held(n, 0);
  for (Index v : fixed) {
    if (v < 0 || static_cast<std::size_t>(v) >= n) throw SetupError("ptc_matrix: fixed filler index out of range");
    held[v] = 1;
  }
  // Free DOF numbering: 3 per free filler.
  std::vector<std::int64_t> dof(n, -1);
  std::int64_t m = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (!held[i]) {
      dof[i] = m;
      m += 3;
    }
  if (m == 0) return out;
  double kmean = 0.0;
  for (double k : net.stiffness) kmean += k;
  kmean = net.size() ? kmean / static_cast<double>(net.size()) : 1.0;
  const double ground = p.regularisation * kmean;

  std::vector<Eigen::Triplet<double>> t;
  t.reserve(36 * net.size() + static_cast<std::size_t>(m));
  Eigen::VectorXd f = Eigen::VectorXd::Zero(m);
  for (std::size_t e = 0; e < net.size(); ++e) {
    const Vec3& nn = net.normal[e];
    const double k = net.stiffness[e];
    const Index ends[2] = {net.a[e], net.b[e]};
    const double sign[2] = {-1.0, 1.0};  // B u = n . (u_b - u_a)
    for (int s = 0; s < 2; ++s) {
      const std::int64_t ds = dof[ends[s]];
      if (ds < 0) continue;
      for (int c = 0; c < 3; ++c) f[ds + c] += k * net.eigen_gap[e] * sign[s] * nn[c];
      for (int q = 0; q < 2; ++q) {
        const std::int64_t dq = dof[ends[q]];
        if (dq < 0) continue;
        for (int c = 0; c < 3; ++c)
          for (int d = 0; d < 3; ++d) t.emplace_back(ds + c, dq + d, k * sign[s] * sign[q] * nn[c] * nn[d]);
      }
    }
  }
  for (std::int64_t i = 0; i < m; ++i) t.emplace_back(i, i, ground);
  Eigen::SparseMatrix<double> K(m, m);
  K.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  ldlt.compute(K);
  if (ldlt.info() != Eigen::Success)
    throw SetupError("ptc_matrix: the spring-network matrix could not be factorised (singular: raise regularisation, or hold fillers)");
  const Eigen::VectorXd u = ldlt.solve(f);
  const double fn = f.norm();
  out.residual = fn > 0.0 ? (K * u - f).norm() / fn : 0.0;
  for (std::size_t i = 0; i < n; ++i)
    if (dof[i] >= 0) out.displacement[i] = Vec3(u[dof[i]], u[dof[i] + 1], u[dof[i] + 2]);
  for (std::size_t e = 0; e < net.size(); ++e) out.opening[e] = net.normal[e].dot(out.displacement[net.b[e]] - out.displacement[net.a[e]]);
  return out;
}

std::size_t Contacts::touching_count() const { return static_cast<std::size_t>(std::count(touching.begin(), touching.end(), char{1})); }

Contacts candidate_contacts(const SpringNetwork& net, const UnitSolution& sol, double touch_gap_rel, double closing_gap_rel) {
  Contacts c;
  const double reach = std::max(touch_gap_rel, closing_gap_rel);
  for (std::size_t e = 0; e < net.size(); ++e)
    if (net.gap[e] <= reach * net.distance[e]) {
      c.a.push_back(net.a[e]);
      c.b.push_back(net.b[e]);
      c.gap.push_back(net.gap[e]);
      c.opening.push_back(sol.opening[e]);
      c.distance.push_back(net.distance[e]);
      c.touching.push_back(net.gap[e] <= touch_gap_rel * net.distance[e] ? 1 : 0);
    }
  return c;
}

double affine_volumetric_strain(const std::vector<Vec3>& x, const std::vector<Vec3>& u) {
  const std::size_t n = x.size();
  if (n < 4 || u.size() != n) throw SetupError("affine_volumetric_strain: needs >= 4 positions with one displacement each");
  Vec3 xm = Vec3::Zero(), um = Vec3::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    xm += x[i];
    um += u[i];
  }
  xm /= static_cast<double>(n);
  um /= static_cast<double>(n);
  Eigen::Matrix3d cux = Eigen::Matrix3d::Zero(), cxx = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 dx = x[i] - xm;
    cux += (u[i] - um) * dx.transpose();
    cxx += dx * dx.transpose();
  }
  const Eigen::LDLT<Eigen::Matrix3d> f(cxx);
  if (f.info() != Eigen::Success || !(f.vectorD().minCoeff() > 1e-12 * f.vectorD().maxCoeff()))
    throw SetupError("affine_volumetric_strain: the positions lie on a plane or a line");
  // A = C_ux C_xx^-1, so A^T = C_xx^-1 C_ux^T (C_xx symmetric).
  return f.solve(cux.transpose()).trace();
}

Intervals conduction_intervals(const Contacts& c, double touch_gap_rel, double break_gap_rel) {
  const std::size_t n = c.size();
  if (c.b.size() != n || c.gap.size() != n || c.opening.size() != n || c.distance.size() != n || c.touching.size() != n)
    throw SetupError("ptc_matrix: a contact set needs a, b, gap, opening, distance and touching of one length each");
  for (std::size_t e = 0; e < n; ++e)
    if (!std::isfinite(c.gap[e]) || !std::isfinite(c.opening[e]) || !(c.distance[e] > 0.0))
      throw SetupError("ptc_matrix: contact " + std::to_string(e) + " has a non-finite gap or opening, or a contact distance <= 0");
  Intervals iv;
  iv.lo.assign(c.size(), -kInf);
  iv.hi.assign(c.size(), kInf);
  for (std::size_t e = 0; e < c.size(); ++e) {
    // Conducts while h + eps0 delta <= T: a half-line in eps0 (header rule).
    const double h = c.gap[e], d = c.opening[e];
    const double T = c.touching[e] ? std::max(break_gap_rel * c.distance[e], h) : touch_gap_rel * c.distance[e];
    if (d > 0.0)
      iv.hi[e] = (T - h) / d;
    else if (d < 0.0)
      iv.lo[e] = (T - h) / d;
    else if (h > T) {
      iv.lo[e] = kInf;
      iv.hi[e] = -kInf;
    }
  }
  return iv;
}

StrainPoint evaluate(std::size_t n, const Contacts& c, const Intervals& iv, double eps0, double unit_conductance,
                     std::span<const Index> high, std::span<const Index> low, LaplacianSolver& solver) {
  if (iv.lo.size() != c.size() || iv.hi.size() != c.size()) throw SetupError("ptc_matrix: one conduction interval per contact expected");
  StrainPoint sp;
  sp.eps0 = eps0;
  std::vector<Index> a, b;
  for (std::size_t e = 0; e < c.size(); ++e)
    if (iv.lo[e] <= eps0 && eps0 <= iv.hi[e]) {
      a.push_back(c.a[e]);
      b.push_back(c.b[e]);
    }
  const percolation::Metrics m = percolation::metrics(n, a, b, high, low);
  sp.spanning = m.spanning;
  sp.conducting = m.touching_pairs;
  sp.coordination = m.coordination;
  sp.resistance = kInf;
  if (m.spanning) {
    const std::vector<double> rk = percolation::cluster_resistances(n, a, b, unit_conductance, high, low, solver);
    double inv = 0.0;
    for (double r : rk) inv += r > 0.0 ? 1.0 / r : kInf;
    sp.resistance = inv > 0.0 ? 1.0 / inv : kInf;
  }
  return sp;
}

namespace {

/// Union-find over the fillers that tells when the electrodes connect.
class Spanning {
 public:
  Spanning(std::size_t n, std::span<const Index> high, std::span<const Index> low) : parent_(n), hi_(n, 0), lo_(n, 0) {
    std::iota(parent_.begin(), parent_.end(), Index{0});
    for (Index v : high) hi_[v] = 1;
    for (Index v : low) lo_[v] = 1;
    for (std::size_t v = 0; v < n; ++v) spans_ = spans_ || (hi_[v] && lo_[v]);  // a filler on both faces
  }
  /// Joins a and b; true once the electrodes are connected.
  bool join(Index a, Index b) {
    Index ra = find(a), rb = find(b);
    if (ra != rb) {
      if (rb < ra) std::swap(ra, rb);
      parent_[rb] = ra;
      hi_[ra] = hi_[ra] || hi_[rb];
      lo_[ra] = lo_[ra] || lo_[rb];
      spans_ = spans_ || (hi_[ra] && lo_[ra]);
    }
    return spans_;
  }
  bool spans() const { return spans_; }

 private:
  Index find(Index v) {
    while (parent_[v] != v) {
      parent_[v] = parent_[parent_[v]];
      v = parent_[v];
    }
    return v;
  }
  std::vector<Index> parent_;
  std::vector<char> hi_, lo_;
  bool spans_ = false;
};

}  // namespace

double switching_strain(std::size_t n, const Contacts& c, const Intervals& iv, std::span<const Index> high, std::span<const Index> low) {
  if (iv.lo.size() != c.size() || iv.hi.size() != c.size()) throw SetupError("ptc_matrix: one conduction interval per contact expected");
  if (n == 0 || high.empty() || low.empty()) return 0.0;
  if (Spanning(n, high, low).spans()) return kInf;
  // 1. The contacts conducting from eps0 = 0 on, in decreasing break strain.
  std::vector<std::size_t> order;
  for (std::size_t e = 0; e < c.size(); ++e)
    if (iv.lo[e] <= 0.0 && iv.hi[e] >= 0.0) order.push_back(e);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return iv.hi[x] > iv.hi[y]; });
  Spanning first(n, high, low);
  double eps1 = -1.0;
  for (std::size_t e : order)
    if (first.join(c.a[e], c.b[e])) {
      eps1 = iv.hi[e];
      break;
    }
  if (eps1 < 0.0) return 0.0;
  if (std::isinf(eps1)) return eps1;
  // 2. Closing contacts (lo > 0) may carry the network past eps1: check each later break strain
  //    (one union-find pass per break above eps1 until one fails: O(breaks x contacts) at worst,
  //    in practice a few passes, as the network fails soon after eps1).
  const bool closing = std::any_of(iv.lo.begin(), iv.lo.end(), [](double v) { return v > 0.0 && std::isfinite(v); });
  if (!closing) return eps1;
  std::vector<double> breaks;
  for (double v : iv.hi)
    if (v >= eps1 && std::isfinite(v)) breaks.push_back(v);
  std::sort(breaks.begin(), breaks.end());
  breaks.erase(std::unique(breaks.begin(), breaks.end()), breaks.end());
  for (double eb : breaks) {
    Spanning after(n, high, low);  // the set just above eb: joined by eb, not broken at eb
    for (std::size_t e = 0; e < c.size() && !after.spans(); ++e)
      if (iv.lo[e] <= eb && iv.hi[e] > eb) after.join(c.a[e], c.b[e]);
    if (!after.spans()) return eb;
  }
  return kInf;
}

}  // namespace sparkdem::physics::ptc
