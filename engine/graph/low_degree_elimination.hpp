#pragma once
/// Exact elimination of the rows of a sparse symmetric positive definite system A x = b that have
/// at most two off-diagonal entries, before an iterative solve of what remains (the Schur
/// complement). Used by LaplacianSolver's Amg method (LaplacianOptions::amg_eliminate_low_degree).
///
/// Equations (Gaussian elimination of one row v, pivot d = A_vv, neighbours u, w):
///     A_uu -= A_uv^2 / d,   A_ww -= A_wv^2 / d,   A_uw -= A_uv A_vw / d,
///     b_u  -= A_uv b_v / d, b_w  -= A_wv b_v / d,
/// and after the solve of the rest, in reverse order of elimination,
///     x_v = (b_v - A_vu x_u - A_vw x_w) / d.
/// On a resistor network this is Kirchhoff's reduction: a node at the end of a dead-end branch
/// (one neighbour) takes its neighbour's potential, two resistors in series through a node with no
/// other branch become one of conductance g1 g2 / (g1 + g2). A row loses v and gains at most w,
/// so no row ever grows: the elimination runs in place, with no fill beyond the pattern.
/// Eliminating a row changes its neighbours' counts, so rows are eliminated from a queue until
/// every remaining row has three or more off-diagonal entries (rows are taken in index order,
/// then as they qualify: deterministic).
///
/// Why (issue 40 item 4, benchmarks/README.md "Network solves"): on the 1e6-node packing network
/// a third of the unknowns (dead-end branches and series chains) go, and with them the
/// nodes whose potentials lagged the AMG residual most (a dead-end branch's constant mode costs
/// almost no residual).
///
/// The residual of the reduced system equals the full system's on the kept rows, and the
/// eliminated rows' residual is zero (exact arithmetic), so a solve of the reduced system to a
/// residual r leaves the full system at the residual r.
#include <cstdint>
#include <vector>

#include <Eigen/SparseCore>

namespace sparkdem {

class LowDegreeElimination {
 public:
  using SpMat = Eigen::SparseMatrix<double>;

  /// Eliminate from A (symmetric, both triangles stored, compressed; positive definite). Replaces
  /// any previous elimination.
  void factor(const SpMat& A);

  /// The Schur complement on the kept rows (numbered in their original order; both triangles,
  /// rows sorted in each column).
  const SpMat& reduced() const { return reduced_; }
  std::size_t eliminated() const { return steps_.size(); }
  std::size_t rows() const { return kept_of_.size(); }

  /// b of the full system -> work (length rows(): b with the elimination applied) and the
  /// right-hand side of the reduced system.
  Eigen::VectorXd reduce_rhs(const Eigen::VectorXd& b, Eigen::VectorXd& work) const;
  /// x of the full system -> its kept entries (an initial guess of the reduced solve).
  Eigen::VectorXd restrict_to_kept(const Eigen::VectorXd& x) const;
  /// The full solution from the reduced one (back-substitution with reduce_rhs's work vector).
  Eigen::VectorXd expand(const Eigen::VectorXd& work, const Eigen::VectorXd& x_kept) const;

 private:
  struct Step {
    std::int32_t row, u, w;  ///< eliminated row and its neighbours at that moment (-1: none)
    double d, a_u, a_w;      ///< pivot and the entries A_vu, A_vw at that moment
  };
  std::vector<Step> steps_;             ///< in order of elimination
  std::vector<std::int32_t> kept_of_;   ///< per full row: index among the kept rows, -1 if eliminated
  std::vector<std::int32_t> full_of_;   ///< per kept row: its full row
  SpMat reduced_;
};

}  // namespace sparkdem
