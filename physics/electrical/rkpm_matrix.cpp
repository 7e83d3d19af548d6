#include "physics/electrical/rkpm_matrix.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "engine/core/error.hpp"
#include "engine/core/parallel.hpp"
#include "engine/graph/hypre_amg.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics::rkpm {

namespace {

using Vec4 = Eigen::Vector4d;
using Mat4 = Eigen::Matrix4d;

/// Gauss-Legendre points and weights on [-1, 1] (Newton on the Legendre recurrence).
void gauss_legendre(int n, std::vector<double>& x, std::vector<double>& w) {
  x.assign(n, 0.0);
  w.assign(n, 0.0);
  for (int i = 0; i < n; ++i) {
    double z = std::cos(kPi * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      if (n == 1) {
        p1 = z;
        p0 = 1.0;
      }
      dp = n * (z * p1 - p0) / (z * z - 1.0);
      const double dz = p1 / dp;
      z -= dz;
      if (std::abs(dz) < 1e-16) break;
    }
    x[i] = z;
    w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
  }
}

/// Uniform cell grid of sphere centres: candidates for "x inside a sphere".
class SphereGrid {
 public:
  SphereGrid(const std::vector<Vec3>& c, const std::vector<double>& r) : c_(c), r_(r) {
    if (c.empty()) return;
    rmax_ = *std::max_element(r.begin(), r.end());
    lo_ = c[0];
    Vec3 hi = c[0];
    for (const Vec3& x : c) {
      lo_ = lo_.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    cell_ = std::max(2.0 * rmax_, 1e-300);
    for (int d = 0; d < 3; ++d) {
      n_[d] = static_cast<int>((hi[d] - lo_[d]) / cell_) + 1;
      while (n_[d] > 256) {
        cell_ *= 2.0;
        n_[d] = static_cast<int>((hi[d] - lo_[d]) / cell_) + 1;
      }
    }
    for (int d = 0; d < 3; ++d) n_[d] = static_cast<int>((hi[d] - lo_[d]) / cell_) + 1;
    start_.assign(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2] + 1, 0);
    std::vector<std::size_t> key(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      key[i] = index(cell_of(c[i], 0), cell_of(c[i], 1), cell_of(c[i], 2));
      ++start_[key[i] + 1];
    }
    for (std::size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
    item_.resize(c.size());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < c.size(); ++i) item_[fill[key[i]]++] = static_cast<std::int64_t>(i);
  }
  /// Index of a sphere (other than `skip`) with |x - c_I| < R_I (strict), or -1.
  std::int64_t inside(const Vec3& x, std::int64_t skip = -1) const {
    std::int64_t found = -1;
    visit_near(x, 0.0, [&](std::int64_t I) {
      if (I == skip) return false;
      found = I;
      return true;
    });
    return found;
  }
  /// Calls f(I) for every sphere whose surface may come within `reach` of x (|x - c_I| < R_I +
  /// reach), until f returns true; returns whether it did.
  template <class F>
  bool visit_near(const Vec3& x, double reach, F&& f) const {
    if (c_.empty()) return false;
    int lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::max(0, static_cast<int>(std::floor((x[d] - rmax_ - reach - lo_[d]) / cell_)));
      hi[d] = std::min(n_[d] - 1, static_cast<int>(std::floor((x[d] + rmax_ + reach - lo_[d]) / cell_)));
      if (lo[d] > hi[d]) return false;
    }
    for (int i = lo[0]; i <= hi[0]; ++i)
      for (int j = lo[1]; j <= hi[1]; ++j)
        for (int k = lo[2]; k <= hi[2]; ++k) {
          const std::size_t key = index(i, j, k);
          for (std::size_t q = start_[key]; q < start_[key + 1]; ++q) {
            const std::int64_t sp = item_[q];
            const double rr = r_[sp] + reach;
            if ((x - c_[sp]).squaredNorm() < rr * rr && f(sp)) return true;
          }
        }
    return false;
  }
  const Vec3& centre(std::int64_t I) const { return c_[I]; }
  double radius(std::int64_t I) const { return r_[I]; }

 private:
  int cell_of(const Vec3& x, int d) const { return std::clamp(static_cast<int>((x[d] - lo_[d]) / cell_), 0, n_[d] - 1); }
  std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(i) * n_[1] + j) * n_[2] + k; }
  const std::vector<Vec3>& c_;
  const std::vector<double>& r_;
  double rmax_ = 0.0, cell_ = 1.0;
  Vec3 lo_ = Vec3::Zero();
  int n_[3] = {1, 1, 1};
  std::vector<std::size_t> start_;
  std::vector<std::int64_t> item_;
};

/// Block-sparse (3x3 blocks) symmetric pattern over "super nodes" (RKPM nodes, then spheres),
/// expanded to a scalar CSR matrix; blocks are added in place.
class BlockMatrix {
 public:
  explicit BlockMatrix(std::vector<std::vector<std::int64_t>> cols) : cols_(std::move(cols)) {
    const std::size_t nb = cols_.size();
    std::size_t nnz = 0;
    row_start_.resize(3 * nb + 1);
    for (std::size_t I = 0; I < nb; ++I) {
      std::sort(cols_[I].begin(), cols_[I].end());
      cols_[I].erase(std::unique(cols_[I].begin(), cols_[I].end()), cols_[I].end());
      for (int c = 0; c < 3; ++c) {
        row_start_[3 * I + c] = nnz;
        nnz += 3 * cols_[I].size();
      }
    }
    row_start_[3 * nb] = nnz;
    if (nnz > static_cast<std::size_t>(std::numeric_limits<int>::max()))
      throw SetupError("rkpm_matrix: the system has " + std::to_string(nnz) +
                       " non-zeros (more than 2^31): raise node_spacing or lower support_factor");
    value_.assign(nnz, 0.0);
  }
  std::size_t position(std::int64_t I, std::int64_t J) const {
    const auto& c = cols_[I];
    const auto it = std::lower_bound(c.begin(), c.end(), J);
    if (it == c.end() || *it != J) throw SetupError("rkpm_matrix: internal error (block outside the sparsity pattern)");
    return static_cast<std::size_t>(it - c.begin());
  }
  void add(std::int64_t I, std::int64_t J, const Eigen::Matrix3d& B) {
    const std::size_t p = position(I, J);
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) value_[row_start_[3 * I + c] + 3 * p + d] += B(c, d);
  }
  void add_scalar(std::int64_t I, std::int64_t J, double s) {  // s x I_3
    const std::size_t p = position(I, J);
    for (int c = 0; c < 3; ++c) value_[row_start_[3 * I + c] + 3 * p + c] += s;
  }
  void add_entry(std::int64_t I, std::int64_t J, int c, int d, double s) { value_[row_start_[3 * I + c] + 3 * position(I, J) + d] += s; }
  Eigen::SparseMatrix<double, Eigen::RowMajor, int> matrix() const {
    const auto n = static_cast<Eigen::Index>(3 * cols_.size());
    Eigen::SparseMatrix<double, Eigen::RowMajor, int> A(n, n);
    A.resizeNonZeros(static_cast<Eigen::Index>(value_.size()));
    for (std::size_t r = 0; r <= 3 * cols_.size(); ++r) A.outerIndexPtr()[r] = static_cast<int>(row_start_[r]);
    for (std::size_t I = 0; I < cols_.size(); ++I)
      for (int c = 0; c < 3; ++c) {
        std::size_t q = row_start_[3 * I + c];
        for (std::int64_t J : cols_[I])
          for (int d = 0; d < 3; ++d) {
            A.innerIndexPtr()[q] = static_cast<int>(3 * J + d);
            A.valuePtr()[q] = value_[q];
            ++q;
          }
      }
    return A;
  }

 private:
  std::vector<std::vector<std::int64_t>> cols_;
  std::vector<std::size_t> row_start_;
  std::vector<double> value_;
};

double quartic(double xi) { return xi >= 1.0 ? 0.0 : 1.0 - xi * xi * (6.0 - 8.0 * xi + 3.0 * xi * xi); }

}  // namespace

// --- Approximation ------------------------------------------------------------------------

Approximation::Approximation(const Vec3& lo, const std::array<int, 3>& cells, double h, double support_factor)
    : lo_(lo), h_(h), rho_(support_factor * h) {
  for (int d = 0; d < 3; ++d) n_[d] = cells[d] + 1;
  std::vector<char> all(grid_nodes(), 1);
  keep(all);
}

void Approximation::keep(const std::vector<char>& flag) {
  if (flag.size() != grid_nodes()) throw SetupError("rkpm_matrix: internal error (node flag size)");
  id_.assign(grid_nodes(), -1);
  position_.clear();
  for (std::size_t g = 0; g < grid_nodes(); ++g)
    if (flag[g]) {
      id_[g] = static_cast<std::int64_t>(position_.size());
      position_.push_back(grid_position(static_cast<std::int64_t>(g)));
    }
}

Vec3 Approximation::grid_position(std::int64_t g) const {
  const std::int64_t k = g % n_[2], j = (g / n_[2]) % n_[1], i = g / (static_cast<std::int64_t>(n_[1]) * n_[2]);
  return lo_ + h_ * Vec3(static_cast<double>(i), static_cast<double>(j), static_cast<double>(k));
}

void Approximation::grid_nodes_near(const Vec3& x, double radius, std::vector<std::int64_t>& out) const {
  out.clear();
  int lo[3], hi[3];
  for (int d = 0; d < 3; ++d) {
    lo[d] = std::max(0, static_cast<int>(std::ceil((x[d] - radius - lo_[d]) / h_)));
    hi[d] = std::min(n_[d] - 1, static_cast<int>(std::floor((x[d] + radius - lo_[d]) / h_)));
  }
  const double r2 = radius * radius;
  for (int i = lo[0]; i <= hi[0]; ++i)
    for (int j = lo[1]; j <= hi[1]; ++j)
      for (int k = lo[2]; k <= hi[2]; ++k) {
        const Vec3 xi = lo_ + h_ * Vec3(i, j, k);
        if ((x - xi).squaredNorm() < r2) out.push_back((static_cast<std::int64_t>(i) * n_[1] + j) * n_[2] + k);
      }
}

void Approximation::kept_nodes_near(const Vec3& x, double radius, std::vector<std::int64_t>& out) const {
  thread_local std::vector<std::int64_t> near;
  grid_nodes_near(x, radius, near);
  out.clear();
  for (std::int64_t g : near)
    if (id_[g] >= 0) out.push_back(id_[g]);
}

bool Approximation::shape(const Vec3& x, std::vector<std::int64_t>& ids, std::vector<double>& phi, std::vector<Vec3>* grad) const {
  thread_local std::vector<std::int64_t> candidates;
  kept_nodes_near(x, rho_, candidates);
  return shape_among(x, candidates, ids, phi, grad);
}

/// The moment derivatives use dp_i/dx_k = e_(k+1) / rho:
///     dM/dx_k = sum_i [w_i (e p_i^T + p_i e^T) / rho + dw_i/dx_k p_i p_i^T]
///             = e s^T + s e^T + sum_i dw_i/dx_k p_i p_i^T,   s = M e_0 / rho (p_i,0 = 1).
bool Approximation::shape_among(const Vec3& x, const std::vector<std::int64_t>& candidates, std::vector<std::int64_t>& ids,
                                std::vector<double>& phi, std::vector<Vec3>* grad) const {
  thread_local std::vector<Vec4> pz;
  thread_local std::vector<double> wv;
  thread_local std::vector<Vec3> dw;
  ids.clear();
  phi.clear();
  pz.clear();
  wv.clear();
  dw.clear();
  Mat4 M = Mat4::Zero();
  Mat4 dM[3] = {Mat4::Zero(), Mat4::Zero(), Mat4::Zero()};
  const double r2 = rho_ * rho_;
  for (std::int64_t id : candidates) {
    const Vec3 d = x - position_[id];
    if (!(d.squaredNorm() < r2)) continue;
    const Vec3 z = d / rho_;
    const double xi = z.norm();
    const double w = quartic(xi);
    if (!(w > 0.0)) continue;
    const Vec4 p(1.0, z.x(), z.y(), z.z());
    const Mat4 ppt = p * p.transpose();
    ids.push_back(id);
    pz.push_back(p);
    wv.push_back(w);
    M.noalias() += w * ppt;
    if (grad) {
      const Vec3 dwi = (-12.0 + 24.0 * xi - 12.0 * xi * xi) / rho_ * z;
      dw.push_back(dwi);
      for (int k = 0; k < 3; ++k) dM[k].noalias() += dwi[k] * ppt;
    }
  }
  if (ids.size() < 4) return false;
  const Eigen::LDLT<Mat4> ldlt(M);
  const Vec4 D = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !(D.minCoeff() > 1e-10 * D.maxCoeff())) return false;
  const Vec4 b = ldlt.solve(Vec4(1.0, 0.0, 0.0, 0.0));
  phi.resize(ids.size());
  for (std::size_t a = 0; a < ids.size(); ++a) phi[a] = b.dot(pz[a]) * wv[a];
  if (grad) {
    const Vec4 s = M.col(0) / rho_;
    Vec4 db[3];
    for (int k = 0; k < 3; ++k) {
      dM[k].row(k + 1) += s.transpose();
      dM[k].col(k + 1) += s;
      db[k] = -ldlt.solve(dM[k] * b);
    }
    grad->resize(ids.size());
    for (std::size_t a = 0; a < ids.size(); ++a) {
      const double bp = b.dot(pz[a]);
      for (int k = 0; k < 3; ++k) (*grad)[a][k] = db[k].dot(pz[a]) * wv[a] + b[k + 1] / rho_ * wv[a] + bp * dw[a][k];
    }
  }
  return true;
}

// --- Result -------------------------------------------------------------------------------

Vec3 Result::displacement(const Vec3& x) const {
  std::vector<std::int64_t> ids;
  std::vector<double> phi;
  if (!approximation.shape(x, ids, phi, nullptr)) throw SetupError("rkpm_matrix: point outside the node cover");
  Vec3 u = Vec3::Zero();
  for (std::size_t a = 0; a < ids.size(); ++a) u += phi[a] * node_coefficient[ids[a]];
  return u;
}

bool Result::displacement_gradient(const Vec3& x, Eigen::Matrix3d& G, GradientScratch& w) const {
  if (!approximation.shape(x, w.ids, w.phi, &w.grad)) return false;
  G.setZero();
  for (std::size_t a = 0; a < w.ids.size(); ++a) G += node_coefficient[w.ids[a]] * w.grad[a].transpose();
  return true;
}

Eigen::Matrix3d Result::displacement_gradient(const Vec3& x) const {
  GradientScratch w;
  Eigen::Matrix3d G;
  if (!displacement_gradient(x, G, w)) throw SetupError("rkpm_matrix: point outside the node cover");
  return G;
}

// --- helpers ------------------------------------------------------------------------------

std::vector<Vec3> sphere_points(int n) {
  if (n < 2 || n % 2 != 0) throw SetupError("rkpm_matrix: surface_points must be even and >= 2, found " + std::to_string(n));
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  std::vector<Vec3> out;
  out.reserve(n);
  for (int k = 0; k < n / 2; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / n;  // upper half: z in (0, 1)
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double t = golden * k;
    out.emplace_back(s * std::cos(t), s * std::sin(t), z);
  }
  for (int k = 0; k < n / 2; ++k) out.push_back(-out[k]);
  return out;
}

std::vector<std::string> parse_box_faces(const std::string& text) {
  if (text == "all") return {kBoxFaces.begin(), kBoxFaces.end()};
  std::vector<std::string> out;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    out.push_back(text.substr(start, comma - start));
    if (std::find(kBoxFaces.begin(), kBoxFaces.end(), out.back()) == kBoxFaces.end())
      throw SetupError("must be \"all\" or a comma-separated list of x_lo, x_hi, y_lo, y_hi, z_lo, z_hi, found \"" + text + "\"");
    start = comma + 1;
  }
  return out;
}

std::array<double, 2> single_sphere_closed_form(double a, double b, double E, double nu, double alpha) {
  const double mu = E / (2.0 * (1.0 + nu));
  const double K = E / (3.0 * (1.0 - 2.0 * nu));
  // sigma_rr(b) = 0:            3K (A - 1) = 4 mu B / b^3
  // sigma_rr(a) = alpha u_r(a): 3K (A - 1) - 4 mu B / a^3 = alpha (A a + B / a^2)
  const double ib3 = std::isfinite(b) ? 1.0 / (b * b * b) : 0.0;
  const double B = alpha * a / (4.0 * mu * ib3 - 4.0 * mu / (a * a * a) - 4.0 * mu * alpha * a * ib3 / (3.0 * K) - alpha / (a * a));
  const double A = 1.0 + 4.0 * mu * B * ib3 / (3.0 * K);
  return {A, B};
}

// --- the solve, in named steps ------------------------------------------------------------

namespace {

struct Material {
  double E = 1.0, lambda = 0.0, mu = 0.0, threeK = 0.0;
  explicit Material(const Params& p)
      : E(p.youngs_modulus),
        lambda(p.youngs_modulus * p.poisson_ratio / ((1.0 + p.poisson_ratio) * (1.0 - 2.0 * p.poisson_ratio))),
        mu(p.youngs_modulus / (2.0 * (1.0 + p.poisson_ratio))),
        threeK(3.0 * lambda + 2.0 * mu) {}
};

/// The matrix domain with its fitted node grid.
struct Frame {
  Vec3 lo = Vec3::Zero(), hi = Vec3::Ones(), c = Vec3::Zero();
  bool ball = false;
  double ball_radius = 0.0;
  double h = 1.0;
  std::array<int, 3> cells{1, 1, 1};
  bool in_domain(const Vec3& x) const {
    if (ball) return (x - c).norm() <= ball_radius;
    for (int d = 0; d < 3; ++d)
      if (x[d] < lo[d] - 1e-12 * h || x[d] > hi[d] + 1e-12 * h) return false;
    return true;
  }
};

struct QPoint {
  Vec3 x;
  double w;
};
struct VolumeQuadrature {
  std::vector<QPoint> points;
  std::vector<std::size_t> cell_start;  ///< points of background cell k: [cell_start[k], cell_start[k+1])
};

void check_params(const std::vector<Vec3>& centre, const std::vector<double>& radius, const Domain& domain, const Params& p) {
  if (centre.size() != radius.size()) throw SetupError("rkpm_matrix: centres and radii differ in length");
  if (!(p.youngs_modulus > 0.0)) throw SetupError("rkpm_matrix: youngs_modulus must be > 0");
  if (!(p.poisson_ratio > -1.0 && p.poisson_ratio < 0.5)) throw SetupError("rkpm_matrix: poisson_ratio must be in (-1, 0.5)");
  if (!(p.node_spacing > 0.0)) throw SetupError("rkpm_matrix: node_spacing must be > 0");
  if (!(p.support_factor > 1.0)) throw SetupError("rkpm_matrix: support_factor must be > 1 (linear basis needs >= 4 nodes in reach)");
  if (p.quadrature_order < 1 || p.quadrature_order > 8) throw SetupError("rkpm_matrix: quadrature_order must be in 1..8");
  if (p.cell_subdivision < 1) throw SetupError("rkpm_matrix: cell_subdivision must be >= 1");
  if (p.cut_cell_depth < 0 || p.cut_cell_depth > 8) throw SetupError("rkpm_matrix: cut_cell_depth must be in 0..8");
  if (!(p.surface_spacing > 0.0)) throw SetupError("rkpm_matrix: surface_spacing must be > 0");
  if (!(p.bond_penalty >= 0.0) || !(p.pin_penalty > 0.0)) throw SetupError("rkpm_matrix: bond_penalty >= 0 and pin_penalty > 0 expected");
  if (p.solver != "cg" && p.solver != "cg_ic" && p.solver != "ldlt" && p.solver != "auto" && p.solver != "amg")
    throw SetupError("rkpm_matrix: solver must be \"cg\", \"cg_ic\", \"ldlt\", \"amg\" or \"auto\", found \"" + p.solver + "\"");
  if (p.boundary != "free" && p.boundary != "clamped" && p.boundary != "rollers")
    throw SetupError("rkpm_matrix: boundary must be \"free\", \"clamped\" or \"rollers\", found \"" + p.boundary + "\"");
  if (p.boundary != "free" && domain.ball_radius > 0.0)
    throw SetupError("rkpm_matrix: boundary \"" + p.boundary + "\" needs a box domain (the ball is traction-free)");
  if (!(p.boundary_penalty > 0.0)) throw SetupError("rkpm_matrix: boundary_penalty must be > 0");
  for (const std::string& face : p.boundary_faces)
    if (std::find(kBoxFaces.begin(), kBoxFaces.end(), face) == kBoxFaces.end())
      throw SetupError("rkpm_matrix: boundary_faces must name x_lo, x_hi, y_lo, y_hi, z_lo or z_hi, found \"" + face + "\"");
  if (p.boundary != "free" && p.boundary_faces.empty())
    throw SetupError("rkpm_matrix: boundary \"" + p.boundary + "\" needs boundary_faces");
  for (std::size_t k = 1; k < p.strain_edges.size(); ++k)
    if (!(p.strain_edges[k] > p.strain_edges[k - 1])) throw SetupError("rkpm_matrix: strain_edges must increase strictly");
  if (p.strain_points != "matrix" && p.strain_points != "box" && p.strain_points != "nodes")
    throw SetupError("rkpm_matrix: strain_points must be \"matrix\", \"box\" or \"nodes\", found \"" + p.strain_points + "\"");
  for (double r : radius)
    if (!(r > 0.0)) throw SetupError("rkpm_matrix: sphere radii must be > 0");
}

/// Node grid: h fits each edge; the box edges must be multiples of one spacing.
Frame fit_frame(const Domain& domain, const Params& p) {
  Frame f;
  f.ball = domain.ball_radius > 0.0;
  f.ball_radius = domain.ball_radius;
  f.c = 0.5 * (domain.lo + domain.hi);
  f.lo = domain.lo;
  f.hi = domain.hi;
  if (f.ball) {
    f.lo = f.c - Vec3::Constant(domain.ball_radius);
    f.hi = f.c + Vec3::Constant(domain.ball_radius);
  }
  if (!((f.hi - f.lo).minCoeff() > 0.0)) throw SetupError("rkpm_matrix: empty domain");
  f.h = 0.0;
  for (int d = 0; d < 3; ++d) {
    f.cells[d] = std::max(1, static_cast<int>(std::lround((f.hi[d] - f.lo[d]) / p.node_spacing)));
    f.h = std::max(f.h, (f.hi[d] - f.lo[d]) / f.cells[d]);
  }
  for (int d = 0; d < 3; ++d)
    if (std::abs(f.cells[d] * f.h - (f.hi[d] - f.lo[d])) > 1e-9 * f.h)
      throw SetupError("rkpm_matrix: the domain edges are not multiples of one node spacing (use a cube)");
  return f;
}

enum class Cover { Empty, Full, Cut };

/// Does the cube (centre o, half edge a) lie wholly in the matrix, wholly outside it (inside a
/// sphere or outside the domain), or is it cut by a sphere surface or the ball boundary?
Cover classify(const Frame& f, const SphereGrid& sg, const Vec3& o, double a) {
  const double hd = std::sqrt(3.0) * a;
  Cover state = Cover::Full;
  if (f.ball) {
    const double d = (o - f.c).norm();
    if (d - hd > f.ball_radius) return Cover::Empty;
    if (d + hd > f.ball_radius) state = Cover::Cut;
  }
  const bool empty = sg.visit_near(o, hd, [&](std::int64_t I) {
    const double d = (o - sg.centre(I)).norm();
    if (d + hd <= sg.radius(I)) return true;  // wholly inside this sphere
    if (d - hd < sg.radius(I)) state = Cover::Cut;
    return false;
  });
  return empty ? Cover::Empty : state;
}

/// Gauss points of the cube (o, a): a full cube keeps them all; a cut cube is split into eight
/// (depth_left > 0) or, at the last level, keeps the points that fall in the matrix.
void cube_points(const Frame& f, const SphereGrid& sg, const Vec3& o, double a, int depth_left, const std::vector<double>& gx,
                 const std::vector<double>& gw, std::vector<QPoint>& out) {
  const Cover cover = classify(f, sg, o, a);
  if (cover == Cover::Empty) return;
  if (cover == Cover::Cut && depth_left > 0) {
    for (int k = 0; k < 8; ++k) {
      const Vec3 s((k & 1) ? 0.5 : -0.5, (k & 2) ? 0.5 : -0.5, (k & 4) ? 0.5 : -0.5);
      cube_points(f, sg, o + a * s, 0.5 * a, depth_left - 1, gx, gw, out);
    }
    return;
  }
  const double vol = a * a * a;  // (2a)^3 / 8: the Gauss weights on [-1, 1]^3 sum to 8
  const std::size_t n = gx.size();
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j)
      for (std::size_t k = 0; k < n; ++k) {
        const Vec3 x = o + a * Vec3(gx[i], gx[j], gx[k]);
        if (cover == Cover::Cut && (!f.in_domain(x) || sg.inside(x) >= 0)) continue;
        out.push_back({x, vol * gw[i] * gw[j] * gw[k]});
      }
}

VolumeQuadrature volume_quadrature(const Frame& f, const SphereGrid& sg, const Params& p) {
  std::vector<double> gx, gw;
  gauss_legendre(p.quadrature_order, gx, gw);
  const int s = p.cell_subdivision;
  const double hc = f.h / s;
  const std::array<int, 3> nc = {f.cells[0] * s, f.cells[1] * s, f.cells[2] * s};
  VolumeQuadrature vq;
  vq.cell_start.reserve(static_cast<std::size_t>(nc[0]) * nc[1] * nc[2] + 1);
  for (int i = 0; i < nc[0]; ++i)
    for (int j = 0; j < nc[1]; ++j)
      for (int k = 0; k < nc[2]; ++k) {
        vq.cell_start.push_back(vq.points.size());
        cube_points(f, sg, f.lo + hc * Vec3(i + 0.5, j + 0.5, k + 0.5), 0.5 * hc, p.cut_cell_depth, gx, gw, vq.points);
      }
  vq.cell_start.push_back(vq.points.size());
  return vq;
}

/// A ball holding every node within rho of some point of background cell `cell` (non-empty): about
/// the centre of the points' bounding box, radius rho + its half diagonal. Returns the radius.
double cell_reach(const Approximation& ap, const VolumeQuadrature& vq, std::size_t cell, Vec3& centre) {
  Vec3 lo = vq.points[vq.cell_start[cell]].x, hi = lo;
  for (std::size_t q = vq.cell_start[cell]; q < vq.cell_start[cell + 1]; ++q) {
    lo = lo.cwiseMin(vq.points[q].x);
    hi = hi.cwiseMax(vq.points[q].x);
  }
  centre = 0.5 * (lo + hi);
  return ap.support() + 0.5 * (hi - lo).norm() + 1e-12 * ap.spacing();
}

/// Keep the nodes whose support holds a volume point (a node deep in a sphere has an empty row).
/// Cell by cell: the grid nodes near the cell's bounding box are looked up once, then each point
/// flags those within rho (the same test as grid_nodes_near).
void keep_supported_nodes(Approximation& ap, const VolumeQuadrature& vq) {
  std::vector<char> flag(ap.grid_nodes(), 0);
  std::vector<std::int64_t> near;
  std::vector<Vec3> xg;
  const double r2 = ap.support() * ap.support();
  for (std::size_t cell = 0; cell + 1 < vq.cell_start.size(); ++cell) {
    const std::size_t q0 = vq.cell_start[cell], q1 = vq.cell_start[cell + 1];
    if (q0 == q1) continue;
    Vec3 centre;
    const double reach = cell_reach(ap, vq, cell, centre);
    ap.grid_nodes_near(centre, reach, near);
    xg.clear();
    for (std::int64_t g : near) xg.push_back(ap.grid_position(g));
    for (std::size_t q = q0; q < q1; ++q)
      for (std::size_t k = 0; k < near.size(); ++k)
        if (!flag[near[k]] && (vq.points[q].x - xg[k]).squaredNorm() < r2) flag[near[k]] = 1;
  }
  ap.keep(flag);
}

/// Block pattern: nodes within 2 rho; sphere I with the nodes within R_I + rho of its centre.
BlockMatrix sparsity(const Approximation& ap, const std::vector<Vec3>& centre, const std::vector<double>& radius) {
  const std::size_t nn = ap.nodes(), ns = centre.size();
  std::vector<std::vector<std::int64_t>> cols(nn + ns);
  std::vector<std::int64_t> near;
  for (std::size_t i = 0; i < nn; ++i) {
    ap.grid_nodes_near(ap.positions()[i], 2.0 * ap.support(), near);
    for (std::int64_t g : near)
      if (ap.id(g) >= 0) cols[i].push_back(ap.id(g));
  }
  for (std::size_t I = 0; I < ns; ++I) {
    const auto S = static_cast<std::int64_t>(nn + I);
    cols[S].push_back(S);
    ap.grid_nodes_near(centre[I], radius[I] + ap.support(), near);
    for (std::int64_t g : near)
      if (ap.id(g) >= 0) {
        cols[S].push_back(ap.id(g));
        cols[ap.id(g)].push_back(S);
      }
  }
  return BlockMatrix(std::move(cols));
}

/// The local (per cell or per sphere) index of node `id`, appended to lnodes on first use.
int local_index(std::vector<int>& local, std::vector<std::int64_t>& lnodes, std::int64_t id) {
  if (local[id] < 0) {
    local[id] = static_cast<int>(lnodes.size());
    lnodes.push_back(id);
  }
  return local[id];
}

/// One background cell's share of the volume integrals: its points' weights, local node indices
/// and gradients (for the load), and the dense local stiffness blocks (a <= b) over its nodes.
struct CellBlocks {
  std::vector<std::int64_t> lnodes;   ///< local index -> kept node id
  std::vector<std::size_t> start{0};  ///< point k's entries: [start[k], start[k+1])
  std::vector<double> w;              ///< point weights
  std::vector<int> l;                 ///< local node of each entry
  std::vector<Vec3> g;                ///< grad phi of each entry
  std::vector<Eigen::Matrix3d> lk;    ///< nl x nl blocks, (a, b) with a <= b
  std::vector<char> touched;
  bool singular = false;  ///< a point had a singular moment matrix
};

/// Fills `out` for background cell `cell`. With G_ab = sum_points w g_a g_b^T over the cell's
/// points (one outer product per node pair and point), the stiffness block K_ij,cd above is
///     K_ab = lambda G_ab + mu G_ab^T + mu tr(G_ab) I
/// (g_b g_a^T = (g_a g_b^T)^T, g_a . g_b = tr(g_a g_b^T)), formed once per pair at the end.
/// Each point's entries are sorted by local index so that only pairs a <= b are visited.
/// `local` (size = kept nodes, all -1) maps node ids to local indices and is left all -1.
void cell_blocks(const Approximation& ap, const VolumeQuadrature& vq, std::size_t cell, const Material& m, std::vector<int>& local,
                 CellBlocks& out) {
  thread_local std::vector<std::int64_t> ids;
  thread_local std::vector<double> phi;
  thread_local std::vector<Vec3> grad;
  thread_local std::vector<std::pair<int, Vec3>> entry;
  out.lnodes.clear();
  out.start.assign(1, 0);
  out.w.clear();
  out.l.clear();
  out.g.clear();
  out.singular = false;
  // Candidate nodes once per cell: within rho of some point of the cell's bounding box.
  thread_local std::vector<std::int64_t> candidates;
  Vec3 centre;
  const double reach = cell_reach(ap, vq, cell, centre);
  ap.kept_nodes_near(centre, reach, candidates);
  for (std::size_t q = vq.cell_start[cell]; q < vq.cell_start[cell + 1]; ++q) {
    const QPoint& qp = vq.points[q];
    if (!ap.shape_among(qp.x, candidates, ids, phi, &grad)) {
      out.singular = true;
      break;
    }
    entry.clear();
    for (std::size_t a = 0; a < ids.size(); ++a) entry.emplace_back(local_index(local, out.lnodes, ids[a]), grad[a]);
    std::sort(entry.begin(), entry.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
    for (const auto& [l, g] : entry) {
      out.l.push_back(l);
      out.g.push_back(g);
    }
    out.w.push_back(qp.w);
    out.start.push_back(out.l.size());
  }
  for (std::int64_t id : out.lnodes) local[id] = -1;
  const std::size_t nl = out.lnodes.size();
  out.lk.assign(nl * nl, Eigen::Matrix3d::Zero());
  out.touched.assign(nl * nl, 0);
  if (out.singular) return;
  for (std::size_t k = 0; k + 1 < out.start.size(); ++k)
    for (std::size_t a = out.start[k]; a < out.start[k + 1]; ++a) {
      const Vec3 ga = out.w[k] * out.g[a];
      const std::size_t row = static_cast<std::size_t>(out.l[a]) * nl;
      for (std::size_t b = a; b < out.start[k + 1]; ++b) {
        const std::size_t key = row + static_cast<std::size_t>(out.l[b]);
        out.lk[key].noalias() += ga * out.g[b].transpose();
        out.touched[key] = 1;
      }
    }
  for (std::size_t key = 0; key < nl * nl; ++key)
    if (out.touched[key]) {
      const Eigen::Matrix3d G = out.lk[key];
      out.lk[key] = m.lambda * G + m.mu * G.transpose();
      out.lk[key].diagonal().array() += m.mu * G.trace();
    }
}

/// Adds one cell's blocks to K and its load 3K w grad(phi) to F, for the nodes (rows) in
/// [row_lo, row_hi) only, point by point in the order of the quadrature: each row receives its
/// contributions in the same order whatever the row range.
void scatter_cell(const CellBlocks& c, const Material& m, std::int64_t row_lo, std::int64_t row_hi, BlockMatrix& K, Eigen::VectorXd& F) {
  const auto mine = [&](std::int64_t id) { return id >= row_lo && id < row_hi; };
  for (std::size_t k = 0; k + 1 < c.start.size(); ++k)
    for (std::size_t a = c.start[k]; a < c.start[k + 1]; ++a)
      if (mine(c.lnodes[c.l[a]])) F.segment<3>(3 * c.lnodes[c.l[a]]) += c.w[k] * m.threeK * c.g[a];
  const std::size_t nl = c.lnodes.size();
  for (std::size_t a = 0; a < nl; ++a)
    for (std::size_t b = a; b < nl; ++b)
      if (c.touched[a * nl + b]) {
        if (mine(c.lnodes[a])) K.add(c.lnodes[a], c.lnodes[b], c.lk[a * nl + b]);
        if (b != a && mine(c.lnodes[b])) K.add(c.lnodes[b], c.lnodes[a], c.lk[a * nl + b].transpose());
      }
}

/// K += int_Omega B^T C B dV and F += int_Omega 3K grad(phi) dV, background cell by cell. The
/// cells' dense local blocks are computed in batches on the OpenMP threads (the shape functions
/// and the block products), then added to K and F in cell order with each thread owning a range
/// of rows, so every entry sums its contributions in one order: K, F and everything after are
/// bit for bit the same on any number of threads.
/// Returns the integrated matrix volume.
double assemble_volume(BlockMatrix& K, Eigen::VectorXd& F, const Approximation& ap, const VolumeQuadrature& vq, const Material& m) {
  std::vector<std::size_t> cells;  // the background cells holding matrix points
  for (std::size_t cell = 0; cell + 1 < vq.cell_start.size(); ++cell)
    if (vq.cell_start[cell] != vq.cell_start[cell + 1]) cells.push_back(cell);
  const int threads = par::threads();
  const std::size_t batch = 64 * static_cast<std::size_t>(threads);  // ~60 MB of blocks at h = 3 R
  std::vector<CellBlocks> blocks(std::min(batch, cells.size()));
  std::vector<std::vector<int>> local(static_cast<std::size_t>(threads), std::vector<int>(ap.nodes(), -1));
  const auto rows = static_cast<std::int64_t>(ap.nodes());
  double volume = 0.0;
  for (std::size_t first = 0; first < cells.size(); first += batch) {
    const auto n = static_cast<std::int64_t>(std::min(batch, cells.size() - first));
#pragma omp parallel for schedule(dynamic, 1) if (threads > 1 && n > 1)
    for (std::int64_t k = 0; k < n; ++k) {
#ifdef _OPENMP
      const auto t = static_cast<std::size_t>(omp_get_thread_num());
#else
      const std::size_t t = 0;
#endif
      cell_blocks(ap, vq, cells[first + static_cast<std::size_t>(k)], m, local[t], blocks[static_cast<std::size_t>(k)]);
    }
    for (std::int64_t k = 0; k < n; ++k) {
      const CellBlocks& c = blocks[static_cast<std::size_t>(k)];
      if (c.singular) throw SetupError("rkpm_matrix: singular moment matrix at a volume point (raise support_factor)");
      for (double w : c.w) volume += w;
    }
#pragma omp parallel if (threads > 1)
    {
#ifdef _OPENMP
      const std::int64_t t = omp_get_thread_num(), nt = omp_get_num_threads();
#else
      const std::int64_t t = 0, nt = 1;
#endif
      for (std::int64_t k = 0; k < n; ++k)
        scatter_cell(blocks[static_cast<std::size_t>(k)], m, rows * t / nt, rows * (t + 1) / nt, K, F);
    }
  }
  return volume;
}

/// Surface points per sphere: at least surface_points, and one per (surface_spacing h)^2 of area.
int surface_count(double R, double h, const Params& p) {
  const double want = 4.0 * kPi * R * R / std::pow(p.surface_spacing * h, 2);
  const double capped = std::min(want, 1e6);
  int n = std::max(p.surface_points, static_cast<int>(std::ceil(capped)));
  return n + (n % 2);
}

/// Sphere penalty alpha int_{dS_I} (u - U_I)^2 dS (points outside the domain or inside another
/// sphere are dropped: no polymer there). Counts the kept surface points into res.
void assemble_surface(BlockMatrix& K, const Approximation& ap, const Frame& f, const SphereGrid& sg, const std::vector<Vec3>& centre,
                      const std::vector<double>& radius, const Params& p, Result& res) {
  const std::size_t nn = ap.nodes();
  std::vector<std::int64_t> ids;
  std::vector<double> phi;
  std::vector<int> local(nn, -1);
  std::vector<std::int64_t> lnodes;
  std::vector<double> lm, lv;
  std::vector<std::pair<int, std::vector<Vec3>>> point_sets;  // cache by count
  struct SP {
    std::vector<int> l;
    std::vector<double> f;
  };
  std::vector<SP> sps;
  for (std::size_t I = 0; I < centre.size(); ++I) {
    const int n = surface_count(radius[I], f.h, p);
    auto it = std::find_if(point_sets.begin(), point_sets.end(), [n](const auto& e) { return e.first == n; });
    if (it == point_sets.end()) it = point_sets.insert(point_sets.end(), {n, sphere_points(n)});
    const std::vector<Vec3>& unit_points = it->second;
    const double w = 4.0 * kPi * radius[I] * radius[I] / static_cast<double>(n);
    lnodes.clear();
    sps.clear();
    double area = 0.0;
    for (const Vec3& e : unit_points) {
      const Vec3 x = centre[I] + radius[I] * e;
      if (!f.in_domain(x) || sg.inside(x, static_cast<std::int64_t>(I)) >= 0) continue;
      if (!ap.shape(x, ids, phi, nullptr))
        throw SetupError("rkpm_matrix: singular moment matrix at a surface point of sphere " + std::to_string(I) +
                         " (raise support_factor)");
      SP sp;
      for (std::size_t a = 0; a < ids.size(); ++a) {
        sp.l.push_back(local_index(local, lnodes, ids[a]));
        sp.f.push_back(phi[a]);
      }
      area += w;
      sps.push_back(std::move(sp));
      ++res.surface_points;
    }
    if (!(area > 0.0)) throw SetupError("rkpm_matrix: sphere " + std::to_string(I) + " has no surface point in contact with the matrix");
    const std::size_t nl = lnodes.size();
    lm.assign(nl * nl, 0.0);
    lv.assign(nl, 0.0);
    for (const SP& sp : sps)
      for (std::size_t a = 0; a < sp.l.size(); ++a) {
        lv[sp.l[a]] += p.bond_penalty * w * sp.f[a];
        for (std::size_t b = 0; b < sp.l.size(); ++b) lm[sp.l[a] * nl + sp.l[b]] += p.bond_penalty * w * sp.f[a] * sp.f[b];
      }
    const auto S = static_cast<std::int64_t>(nn + I);
    for (std::size_t a = 0; a < nl; ++a) {
      for (std::size_t b = 0; b < nl; ++b)
        if (lm[a * nl + b] != 0.0) K.add_scalar(lnodes[a], lnodes[b], lm[a * nl + b]);
      if (lv[a] != 0.0) {
        K.add_scalar(lnodes[a], S, -lv[a]);
        K.add_scalar(S, lnodes[a], -lv[a]);
      }
    }
    K.add_scalar(S, S, p.bond_penalty * area);
    for (std::int64_t id : lnodes) local[id] = -1;
  }
}

/// Essential conditions. "free": statically determinate pins (no reaction under the
/// self-equilibrated thermal load). "clamped" / "rollers": beta int_{dOmega} |u|^2 (resp.
/// (u.n)^2) dS over the box faces listed in boundary_faces (u-bar = 0), beta = boundary_penalty E / h, Gauss points on
/// the background cells of each face (points inside a sphere dropped).
void assemble_boundary(BlockMatrix& K, const Approximation& ap, const Frame& f, const SphereGrid& sg, std::size_t spheres, const Params& p,
                       const Material& m) {
  std::vector<std::int64_t> ids;
  std::vector<double> phi;
  auto penalise = [&](const Vec3& x, double beta, const Vec3* normal, int comp_mask) {
    if (!ap.shape(x, ids, phi, nullptr)) throw SetupError("rkpm_matrix: singular moment matrix at a boundary point");
    for (std::size_t a = 0; a < ids.size(); ++a)
      for (std::size_t b = 0; b < ids.size(); ++b) {
        const double s = beta * phi[a] * phi[b];
        if (normal) {
          for (int c = 0; c < 3; ++c)
            for (int d = 0; d < 3; ++d) K.add_entry(ids[a], ids[b], c, d, s * (*normal)[c] * (*normal)[d]);
        } else {
          for (int c = 0; c < 3; ++c)
            if (comp_mask & (1 << c)) K.add_entry(ids[a], ids[b], c, c, s);
        }
      }
  };
  if (p.boundary == "free") {
    const double beta = p.pin_penalty * m.E * f.h;
    penalise(f.c, beta, nullptr, 7);
    if (spheres == 0) {  // without spheres the rigid rotations are free too: 3-2-1 pins
      const double arm = 0.25 * (f.hi - f.lo).minCoeff();
      penalise(f.c + Vec3(arm, 0, 0), beta, nullptr, 2 | 4);
      penalise(f.c + Vec3(0, arm, 0), beta, nullptr, 4);
    }
    return;
  }
  std::vector<double> gx, gw;
  gauss_legendre(p.quadrature_order, gx, gw);
  const double beta = p.boundary_penalty * m.E / f.h;
  const int s = p.cell_subdivision;
  const double hc = f.h / s;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const std::string& face = kBoxFaces[static_cast<std::size_t>(2 * axis + side)];
      if (std::find(p.boundary_faces.begin(), p.boundary_faces.end(), face) == p.boundary_faces.end()) continue;
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      Vec3 normal = Vec3::Zero();
      normal[axis] = side ? 1.0 : -1.0;
      for (int i = 0; i < f.cells[u] * s; ++i)
        for (int j = 0; j < f.cells[v] * s; ++j)
          for (std::size_t a = 0; a < gx.size(); ++a)
            for (std::size_t b = 0; b < gx.size(); ++b) {
              Vec3 x;
              x[axis] = side ? f.hi[axis] : f.lo[axis];
              x[u] = f.lo[u] + hc * (i + 0.5 + 0.5 * gx[a]);
              x[v] = f.lo[v] + hc * (j + 0.5 + 0.5 * gx[b]);
              if (sg.inside(x) >= 0) continue;
              const double w = 0.25 * hc * hc * gw[a] * gw[b];
              penalise(x, beta * w, p.boundary == "rollers" ? &normal : nullptr, 7);
            }
    }
}

/// Solves A x = F by the chosen method; fills iterations, residual, solve time; throws if the
/// solve stops above cg_tolerance.
Eigen::VectorXd solve_system(const Eigen::SparseMatrix<double, Eigen::RowMajor, int>& A, const Eigen::VectorXd& F, const Params& p,
                             Result& res) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool direct = p.solver == "ldlt" || (p.solver == "auto" && res.unknowns <= p.direct_limit);
  Eigen::VectorXd x;
  bool ok = true;
  if (direct) {
    const Eigen::SparseMatrix<double> Ac = A;  // column-major copy for the factorisation
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(Ac);
    ok = ldlt.info() == Eigen::Success;
    if (ok) x = ldlt.solve(F);
    res.iterations = 0;
  } else if (p.solver == "amg") {
    HypreAmgPcg::Settings s;
    s.num_functions = 3;
    s.strong_threshold = p.amg_strong_threshold;
    s.aggressive_levels = 0;
    HypreAmgPcg amg(s);
    amg.setup(Eigen::SparseMatrix<double>(A));
    x = Eigen::VectorXd::Zero(F.size());
    const HypreAmgPcg::Outcome o = amg.solve(F, x, p.cg_tolerance, p.cg_max_iterations);
    res.iterations = o.iterations;
    ok = o.converged;
  } else if (p.solver == "cg_ic" || p.solver == "auto") {
    // Both triangles, row-major: the operator product runs row by row on the OpenMP threads (each
    // row summed in one order on any thread count); the factor is the lower triangle's.
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double, Eigen::RowMajor, int>, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double>>
        cg;
    cg.setTolerance(p.cg_tolerance);
    cg.setMaxIterations(p.cg_max_iterations);
    cg.compute(A);
    x = cg.solve(F);
    res.iterations = static_cast<int>(cg.iterations());
    ok = cg.info() == Eigen::Success;
  } else {
    Eigen::ConjugateGradient<Eigen::SparseMatrix<double, Eigen::RowMajor, int>, Eigen::Lower | Eigen::Upper, Eigen::DiagonalPreconditioner<double>> cg;
    cg.setTolerance(p.cg_tolerance);
    cg.setMaxIterations(p.cg_max_iterations);
    cg.compute(A);
    x = cg.solve(F);
    res.iterations = static_cast<int>(cg.iterations());
    ok = cg.info() == Eigen::Success;
  }
  const double fn = F.norm();
  res.residual = ok && fn > 0.0 ? (A * x - F).norm() / fn : (ok ? 0.0 : std::numeric_limits<double>::infinity());
  res.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!ok || !(res.residual <= 10.0 * p.cg_tolerance))
    throw SetupError(std::string("rkpm_matrix: the ") + (direct ? "LDLT" : "conjugate-gradient") + " solve stopped at relative residual " +
                     std::to_string(res.residual) + " after " + std::to_string(res.iterations) + " iterations (cg_tolerance " +
                     std::to_string(p.cg_tolerance) + "): raise cg_max_iterations");
  return x;
}

/// The points the strain statistics sample (Params::strain_points): the matrix volume quadrature
/// ("matrix"), the cell centres of a lattice at spacing h / cell_subdivision over the whole domain
/// with equal weights ("box": filler interiors included), or the kept nodes with weight 1 ("nodes").
std::vector<QPoint> strain_sample_points(const Result& res, const VolumeQuadrature& vq, const Domain& domain, const Params& p) {
  if (p.strain_points == "matrix") return vq.points;
  std::vector<QPoint> out;
  if (p.strain_points == "nodes") {
    for (const Vec3& x : res.approximation.positions()) out.push_back({x, 1.0});
    return out;
  }
  const double step = res.approximation.spacing() / p.cell_subdivision;
  const Vec3 size = domain.hi - domain.lo, mid = 0.5 * (domain.lo + domain.hi);
  std::array<int, 3> n{};
  for (int d = 0; d < 3; ++d) n[d] = std::max(1, static_cast<int>(std::ceil(size[d] / step)));
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i) {
        const Vec3 x = domain.lo + Vec3((i + 0.5) * size[0] / n[0], (j + 0.5) * size[1] / n[1], (k + 0.5) * size[2] / n[2]);
        if (domain.ball_radius > 0.0 && (x - mid).norm() > domain.ball_radius) continue;
        out.push_back({x, 1.0});
      }
  return out;
}

/// Max principal strain of the solved field at the sample points (per unit eps0): total
/// eps = sym(grad u) and mechanical eps - I; weighted histograms over strain_edges
/// (m + 1 edges -> m bins, then below / above), means and the negative fractions. A "box" point
/// outside the node cover is counted in `uncovered` and left out.
void strain_statistics(Result& res, const VolumeQuadrature& vq, const Domain& domain, const Params& p) {
  const std::vector<double>& e = p.strain_edges;
  const std::size_t m = e.size() >= 2 ? e.size() - 1 : 0;
  StrainStatistics& st = res.strain;
  st.total_histogram.assign(m + 2, 0.0);
  st.mechanical_histogram.assign(m + 2, 0.0);
  auto bin = [&](double v) -> std::size_t {
    if (v < e.front()) return m;
    if (v >= e.back()) return m + 1;
    return static_cast<std::size_t>(std::upper_bound(e.begin(), e.end(), v) - e.begin()) - 1;
  };
  const std::vector<QPoint> points = strain_sample_points(res, vq, domain, p);
  Result::GradientScratch scratch;
  Eigen::Matrix3d G;
  double vol = 0.0, mt = 0.0, mm = 0.0, nt = 0.0, nm = 0.0;
  for (const QPoint& q : points) {
    if (!res.displacement_gradient(q.x, G, scratch)) {
      if (p.strain_points != "box") throw SetupError("rkpm_matrix: strain sample point outside the node cover");
      ++st.uncovered;
      continue;
    }
    const Eigen::Matrix3d eps = 0.5 * (G + G.transpose());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(eps, Eigen::EigenvaluesOnly);
    const double total = es.eigenvalues().maxCoeff(), mech = total - 1.0;
    ++st.points;
    vol += q.w;
    mt += q.w * total;
    mm += q.w * mech;
    if (total < 0.0) nt += q.w;
    if (mech < 0.0) nm += q.w;
    if (m > 0) {
      st.total_histogram[bin(total)] += q.w;
      st.mechanical_histogram[bin(mech)] += q.w;
    }
  }
  if (vol > 0.0) {
    for (double& h : st.total_histogram) h /= vol;
    for (double& h : st.mechanical_histogram) h /= vol;
    st.total_mean = mt / vol;
    st.mechanical_mean = mm / vol;
    st.total_negative_fraction = nt / vol;
    st.mechanical_negative_fraction = nm / vol;
  }
  st.evaluated = true;
}

}  // namespace

Result solve_unit(const std::vector<Vec3>& centre, const std::vector<double>& radius, const Domain& domain, const Params& p) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  check_params(centre, radius, domain, p);
  const Material mat(p);
  const Frame f = fit_frame(domain, p);
  Result res;
  res.approximation = Approximation(f.lo, f.cells, f.h, p.support_factor);
  Approximation& ap = res.approximation;
  const SphereGrid spheres(centre, radius);
  const VolumeQuadrature vq = volume_quadrature(f, spheres, p);
  keep_supported_nodes(ap, vq);
  const std::size_t nn = ap.nodes(), ns = centre.size();
  if (nn == 0) throw SetupError("rkpm_matrix: no volume quadrature point in the domain");
  res.volume_points = vq.points.size();
  BlockMatrix K = sparsity(ap, centre, radius);
  Eigen::VectorXd F = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * (nn + ns)));
  res.quadrature_volume = assemble_volume(K, F, ap, vq, mat);
  assemble_surface(K, ap, f, spheres, centre, radius, p, res);
  assemble_boundary(K, ap, f, spheres, ns, p, mat);
  res.assembly_seconds = std::chrono::duration<double>(clock::now() - t0).count();

  const Eigen::SparseMatrix<double, Eigen::RowMajor, int> A = K.matrix();
  res.unknowns = static_cast<std::size_t>(A.rows());
  res.nonzeros = static_cast<std::size_t>(A.nonZeros());
  const Eigen::VectorXd x = solve_system(A, F, p, res);
  res.node_coefficient.resize(nn);
  for (std::size_t i = 0; i < nn; ++i) res.node_coefficient[i] = x.segment<3>(3 * i);
  res.sphere_displacement.resize(ns);
  for (std::size_t I = 0; I < ns; ++I) res.sphere_displacement[I] = x.segment<3>(3 * (nn + I));
  if (p.strain_statistics) {
    const auto t2 = clock::now();
    strain_statistics(res, vq, domain, p);
    res.strain.seconds = std::chrono::duration<double>(clock::now() - t2).count();
  }
  return res;
}

}  // namespace sparkdem::physics::rkpm
