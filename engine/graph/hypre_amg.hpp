#pragma once
/// hypre's BoomerAMG as the preconditioner of hypre's conjugate gradients, on one process.
/// Internal to LaplacianSolver (LaplacianMethod::Amg): no hypre or MPI header leaks from here.
///
/// MPI. hypre needs MPI even on one process. ensure_mpi() initialises it the first time it is
/// needed, unless someone (a launcher-started program, a later distributed driver) already did;
/// only then is it finalised at exit. So `sparkdem run` needs no mpirun and pays nothing for MPI
/// unless a solve uses Amg. All hypre objects live on MPI_COMM_SELF (serial solve per process).
#include <memory>

#include <Eigen/SparseCore>

namespace sparkdem {

/// Initialise MPI (thread level FUNNELED: only the calling thread calls MPI/hypre; OpenMP
/// threads elsewhere do not) and hypre once per process, if MPI is not initialised yet.
/// Registers MPI_Finalize at exit when it initialised MPI itself. Thread-safe. Throws SetupError
/// if MPI cannot be initialised or was already finalised.
void ensure_mpi();

class HypreAmgPcg {
 public:
  struct Settings {
    double strong_threshold = 0.5;  ///< BoomerAMG strength threshold (0.5 is hypre's advice for 3-D)
    int aggressive_levels = 1;      ///< levels of aggressive coarsening (cheaper setup, more PCG iterations)
  };
  struct Outcome {
    int iterations = 0;
    double relative_residual = 0.0;  ///< hypre's final ||r|| / ||b|| (recursive residual)
    bool converged = false;
  };

  HypreAmgPcg();
  explicit HypreAmgPcg(Settings s);
  ~HypreAmgPcg();
  HypreAmgPcg(const HypreAmgPcg&) = delete;
  HypreAmgPcg& operator=(const HypreAmgPcg&) = delete;

  /// Copy the symmetric matrix A (both triangles stored, compressed) into hypre and build the
  /// AMG hierarchy. Replaces any previous setup.
  void setup(const Eigen::SparseMatrix<double>& A);
  bool ready() const;
  /// PCG on the last setup's matrix: stop when ||b - A x||_2 <= tol ||b||_2; x is the initial
  /// guess on entry (warm start) and the iterate on return.
  Outcome solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, double tol, int max_iterations);

 private:
  struct Impl;
  Settings settings_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sparkdem
