#pragma once
/// hypre's BoomerAMG as the preconditioner of hypre's conjugate gradients, on one process or
/// spread over the ranks of an MPI run (see set_amg_spread_ranks).
/// Used by LaplacianSolver (LaplacianMethod::Amg) and by the RKPM matrix solve (rkpm_matrix, solver
/// "amg", num_functions 3): no hypre or MPI header leaks from here.
///
/// MPI. hypre needs MPI even on one process. ensure_mpi() initialises it the first time it is
/// needed, unless someone (a launcher-started program, a later distributed driver) already did;
/// only then is it finalised at exit. So `sparkdem run` needs no mpirun and pays nothing for MPI
/// unless a solve uses Amg. All hypre objects live on MPI_COMM_SELF (serial solve per process).
#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/SparseCore>

namespace sparkdem {

/// Initialise MPI (thread level FUNNELED: only the calling thread calls MPI/hypre; OpenMP
/// threads elsewhere do not) and hypre once per process, if MPI is not initialised yet.
/// Registers MPI_Finalize at exit when it initialised MPI itself. Thread-safe. Throws SetupError
/// if MPI cannot be initialised or was already finalised.
void ensure_mpi();

/// Spread solves. On a run over several MPI ranks (io/mpi/ranks.hpp) rank 0 may spread an AMG
/// solve over `ranks` ranks (hypre's parallel IJ interface; rows cut into contiguous blocks, one
/// per rank) while the other ranks wait for work: the io layer sets this to the number of ranks
/// outside sweep stages and to 1 during them (when the other ranks run items). Default 1 (every
/// solve on MPI_COMM_SELF). Only rank 0 spreads; the others join through serve_amg_command.
void set_amg_spread_ranks(int ranks);
int amg_spread_ranks();
/// MPI tags of rank 0's commands to the other ranks and of their data (on MPI_COMM_WORLD).
inline constexpr int kAmgCommandTag = 10;
inline constexpr int kAmgDataTag = 11;
/// On a rank other than 0: carry out one command of rank 0 (the bytes of a message with tag
/// kAmgCommandTag): set up a spread solver's block, solve with it (collective over the ranks) and
/// send the block of the solution back, or destroy it.
void serve_amg_command(const std::string& bytes);
/// On a rank other than 0 of a program that only serves spread solves (benchmarks, tests): carry
/// out rank 0's commands until a message with `stop_tag` arrives (probing every millisecond).
void serve_amg_commands_until(int stop_tag);

class HypreAmgPcg {
 public:
  struct Settings {
    double strong_threshold = 0.5;  ///< BoomerAMG strength threshold (0.5 is hypre's advice for 3-D)
    int aggressive_levels = 1;      ///< levels of aggressive coarsening (cheaper setup, more PCG iterations)
    /// Spread over the ranks (amg_spread_ranks() > 1) only systems of at least this many rows:
    /// below it the messages cost more than the second rank saves.
    std::int64_t spread_min_rows = 200000;
    /// Hand hypre the rows in breadth-first order (each connected component from a
    /// pseudo-peripheral row) rather than as numbered: neighbours sit close in memory, and the
    /// blocks of a spread solve share thin interfaces. Measured on one process (1e6 nodes, to
    /// 1e-8): a random packing network 4.85 -> 3.54 s, a lattice numbered by layers 2.01 -> 1.85 s.
    bool breadth_first = true;
    /// Unknowns per node of a system (BoomerAMG's "unknown" approach: row r belongs to function
    /// r mod num_functions, and only couplings between equal functions make strength), e.g. 3
    /// for the displacement components of an elasticity matrix numbered node by node. Above 1
    /// the rows keep their numbering (no breadth-first order) and the solve stays on this process.
    int num_functions = 1;
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
  /// Ranks the last setup spread the matrix over (1: this process alone).
  int ranks() const;
  /// PCG on the last setup's matrix: stop when ||b - A x||_2 <= tol ||b||_2; x is the initial
  /// guess on entry (warm start) and the iterate on return.
  Outcome solve(const Eigen::VectorXd& b, Eigen::VectorXd& x, double tol, int max_iterations);

 private:
  friend void serve_amg_command(const std::string& bytes);
  /// On a rank other than 0 of a program that only serves spread solves (benchmarks, tests): carry
  /// out rank 0's commands until a message with `stop_tag` arrives (probing every millisecond).
  void serve_amg_commands_until(int stop_tag);
  struct Impl;
  Settings settings_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sparkdem
