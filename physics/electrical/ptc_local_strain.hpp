#pragma once
/// # ptc_local_strain — the bonded-network matrix of ptc_matrix.hpp under a LOCAL eigenstrain
///
/// Source: /work/shared/physics/cpc-and-networks.md §1.6 "Temperature coupling": with Joule
/// heating a locally varying eps0(x) enters the same linear solve as a right-hand side. The
/// model (springs, stiffness, regularisation) is exactly ptc_matrix.hpp's; only the eigen-
/// elongation of spring e becomes eps0_e h*_e with its own eps0_e (e.g. eps0(T) at the mean
/// temperature of its two fillers), so
///     K u = f,   f = sum_e k_e eps0_e h*_e B_e^T,   opening_e = B_e u = n_e . (u_b - u_a).
/// K depends on the geometry only: it is assembled and factorised (Eigen SimplicialLDLT) ONCE,
/// and every new temperature field costs one forward/back substitution. With a uniform eps0 the
/// result is eps0 times ptc::solve_unit's (the same matrix and right-hand side, scaled).
#include <span>
#include <vector>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "engine/core/types.hpp"
#include "physics/electrical/ptc_matrix.hpp"

namespace sparkdem::physics::ptc {

class LocalStrainSolver {
 public:
  /// Assembles and factorises K of `net` on nodes 0..n-1 (free expansion; nothing held).
  /// Throws SetupError if the factorisation fails.
  void factorize(std::size_t n, const SpringNetwork& net, const MatrixParams& p);
  bool ready() const { return ready_; }
  /// Displacements [m] and spring openings [m] for one eps0 [1] per spring of the network
  /// given to factorize().
  void solve(std::span<const double> eps0_spring, std::vector<Vec3>& displacement, std::vector<double>& opening) const;

 private:
  bool ready_ = false;
  std::size_t n_ = 0;
  SpringNetwork net_;
  Eigen::SparseMatrix<double> K_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt_;
};

}  // namespace sparkdem::physics::ptc
