#include "engine/graph/low_degree_elimination.hpp"

#include <cmath>
#include <limits>
#include <string>

#include "engine/core/error.hpp"

namespace sparkdem {

namespace {

/// The off-diagonal entries of a symmetric matrix as rows that can only shrink: row v holds
/// len[v] live entries from start[v] on; the diagonal apart.
struct ShrinkingRows {
  std::vector<std::int64_t> start;
  std::vector<std::int32_t> len, col;
  std::vector<double> val, diag;

  explicit ShrinkingRows(const Eigen::SparseMatrix<double>& A) {
    const auto n = static_cast<std::size_t>(A.rows());
    start.assign(n + 1, 0);
    len.assign(n, 0);
    diag.assign(n, 0.0);
    col.reserve(static_cast<std::size_t>(A.nonZeros()));
    val.reserve(static_cast<std::size_t>(A.nonZeros()));
    for (std::size_t v = 0; v < n; ++v) {  // symmetric: column v is row v
      start[v] = static_cast<std::int64_t>(col.size());
      for (int k = A.outerIndexPtr()[v]; k < A.outerIndexPtr()[v + 1]; ++k) {
        const int r = A.innerIndexPtr()[k];
        if (r == static_cast<int>(v)) {
          diag[v] += A.valuePtr()[k];
        } else {
          col.push_back(r);
          val.push_back(A.valuePtr()[k]);
        }
      }
      len[v] = static_cast<std::int32_t>(col.size() - static_cast<std::size_t>(start[v]));
    }
    start[n] = static_cast<std::int64_t>(col.size());
  }
  /// Slot of entry (v, c) in row v, -1 if absent.
  std::int64_t find(std::int32_t v, std::int32_t c) const {
    for (std::int64_t k = start[v]; k < start[v] + len[v]; ++k)
      if (col[k] == c) return k;
    return -1;
  }
  /// Remove slot k of row v (the row's last live entry takes its place).
  void remove(std::int32_t v, std::int64_t k) {
    const std::int64_t last = start[v] + --len[v];
    col[k] = col[last];
    val[k] = val[last];
  }
  /// Row u after the elimination of its neighbour v (entry a_uv; the other neighbour of v is w
  /// with entry a_vw, or w = -1): A_uu -= a_uv^2 / d, A_uw -= a_uv a_vw / d, entry v gone.
  void update(std::int32_t u, std::int32_t v, double a_uv, std::int32_t w, double a_vw, double d) {
    diag[u] -= a_uv * a_uv / d;
    const std::int64_t kv = find(u, v);
    if (w < 0) {
      remove(u, kv);
      return;
    }
    const std::int64_t kw = find(u, w);
    if (kw >= 0) {
      val[kw] -= a_uv * a_vw / d;
      remove(u, kv);
    } else {  // the entry of v becomes the entry of w: the row does not grow
      col[kv] = w;
      val[kv] = -a_uv * a_vw / d;
    }
  }
};

}  // namespace

void LowDegreeElimination::factor(const SpMat& A) {
  if (A.rows() != A.cols() || !A.isCompressed()) throw SetupError("LowDegreeElimination: the matrix must be square and compressed");
  if (A.rows() >= std::numeric_limits<std::int32_t>::max())
    throw SetupError("LowDegreeElimination: " + std::to_string(A.rows()) + " rows; at most 2^31 - 2 are supported");
  const auto n = static_cast<std::int32_t>(A.rows());
  ShrinkingRows m(A);
  steps_.clear();
  std::vector<char> gone(static_cast<std::size_t>(n), 0);
  std::vector<std::int32_t> queue;
  for (std::int32_t v = 0; v < n; ++v)
    if (m.len[v] <= 2) queue.push_back(v);
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::int32_t v = queue[q];
    const double d = m.diag[v];
    if (gone[v] || m.len[v] > 2 || !(d > 0.0) || !std::isfinite(d)) continue;  // a row that is not positive stays
    Step s{v, -1, -1, d, 0.0, 0.0};
    if (m.len[v] > 0) {
      s.u = m.col[m.start[v]];
      s.a_u = m.val[m.start[v]];
    }
    if (m.len[v] > 1) {
      s.w = m.col[m.start[v] + 1];
      s.a_w = m.val[m.start[v] + 1];
    }
    if (s.u >= 0) m.update(s.u, v, s.a_u, s.w, s.a_w, d);
    if (s.w >= 0) m.update(s.w, v, s.a_w, s.u, s.a_u, d);
    m.len[v] = 0;
    gone[v] = 1;
    steps_.push_back(s);
    for (const std::int32_t nb : {s.u, s.w})
      if (nb >= 0 && m.len[nb] <= 2) queue.push_back(nb);
  }
  // The kept rows in their order, each column's rows sorted.
  kept_of_.assign(static_cast<std::size_t>(n), -1);
  full_of_.clear();
  for (std::int32_t v = 0; v < n; ++v)
    if (!gone[v]) {
      kept_of_[v] = static_cast<std::int32_t>(full_of_.size());
      full_of_.push_back(v);
    }
  const auto k = static_cast<Eigen::Index>(full_of_.size());
  std::int64_t nnz = k;
  for (const std::int32_t v : full_of_) nnz += m.len[v];
  reduced_.resize(k, k);
  reduced_.resizeNonZeros(static_cast<Eigen::Index>(nnz));
  int* outer = reduced_.outerIndexPtr();
  int* inner = reduced_.innerIndexPtr();
  double* value = reduced_.valuePtr();
  int at = 0;
  outer[0] = 0;
  for (Eigen::Index c = 0; c < k; ++c) {
    const std::int32_t v = full_of_[static_cast<std::size_t>(c)];
    const int first = at;
    inner[at] = static_cast<int>(c);
    value[at++] = m.diag[v];
    for (std::int64_t e = m.start[v]; e < m.start[v] + m.len[v]; ++e) {
      inner[at] = kept_of_[m.col[e]];
      value[at++] = m.val[e];
    }
    for (int i = first + 1; i < at; ++i)  // insertion sort: a column holds a few entries
      for (int j = i; j > first && inner[j] < inner[j - 1]; --j) {
        std::swap(inner[j], inner[j - 1]);
        std::swap(value[j], value[j - 1]);
      }
    outer[c + 1] = at;
  }
}

Eigen::VectorXd LowDegreeElimination::reduce_rhs(const Eigen::VectorXd& b, Eigen::VectorXd& work) const {
  if (b.size() != static_cast<Eigen::Index>(kept_of_.size())) throw SetupError("LowDegreeElimination::reduce_rhs: wrong length");
  work = b;
  for (const Step& s : steps_) {
    if (s.u >= 0) work[s.u] -= s.a_u / s.d * work[s.row];
    if (s.w >= 0) work[s.w] -= s.a_w / s.d * work[s.row];
  }
  Eigen::VectorXd out(static_cast<Eigen::Index>(full_of_.size()));
  for (std::size_t c = 0; c < full_of_.size(); ++c) out[static_cast<Eigen::Index>(c)] = work[full_of_[c]];
  return out;
}

Eigen::VectorXd LowDegreeElimination::restrict_to_kept(const Eigen::VectorXd& x) const {
  Eigen::VectorXd out(static_cast<Eigen::Index>(full_of_.size()));
  for (std::size_t c = 0; c < full_of_.size(); ++c) out[static_cast<Eigen::Index>(c)] = x[full_of_[c]];
  return out;
}

Eigen::VectorXd LowDegreeElimination::expand(const Eigen::VectorXd& work, const Eigen::VectorXd& x_kept) const {
  Eigen::VectorXd x(static_cast<Eigen::Index>(kept_of_.size()));
  for (std::size_t c = 0; c < full_of_.size(); ++c) x[full_of_[c]] = x_kept[static_cast<Eigen::Index>(c)];
  for (auto it = steps_.rbegin(); it != steps_.rend(); ++it) {
    double r = work[it->row];
    if (it->u >= 0) r -= it->a_u * x[it->u];
    if (it->w >= 0) r -= it->a_w * x[it->w];
    x[it->row] = r / it->d;
  }
  return x;
}

}  // namespace sparkdem
