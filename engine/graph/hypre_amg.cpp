#include "engine/graph/hypre_amg.hpp"

#include <mpi.h>

#include <HYPRE.h>
#include <HYPRE_IJ_mv.h>
#include <HYPRE_parcsr_ls.h>

#include <cstdlib>
#include <mutex>
#include <string>
#include <vector>

#include "engine/core/error.hpp"

namespace sparkdem {

namespace {

/// MPI_Finalize (and hypre's) at exit, registered only when ensure_mpi() initialised MPI.
void finalize_mpi_at_exit() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (finalized) return;
  HYPRE_Finalize();
  MPI_Finalize();
}

/// True once MPI is finalised: hypre objects that outlive it (a static solver) are leaked, not
/// destroyed, at exit.
bool mpi_gone() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  return finalized != 0;
}

void check(HYPRE_Int code, const char* call) {
  if (code == 0) return;
  char text[256] = {};
  HYPRE_DescribeError(code, text);
  HYPRE_ClearAllErrors();
  throw SetupError(std::string("hypre: ") + call + " failed (error " + std::to_string(code) + ": " + text + ")");
}

}  // namespace

void ensure_mpi() {
  static std::once_flag once;
  static std::string failure;
  std::call_once(once, [] {
    int initialized = 0, finalized = 0;
    MPI_Initialized(&initialized);
    MPI_Finalized(&finalized);
    if (finalized) {
      failure = "MPI was finalised before the first AMG solve; hypre cannot run";
      return;
    }
    bool own = false;
    if (!initialized) {
      // Started without a launcher (the normal case): Open MPI's singleton start would fork a
      // helper daemon (orted) that this serial use never needs. Not overridden if set; no
      // effect under mpirun (then the launcher's variables are present) or with another MPI.
      if (!std::getenv("OMPI_COMM_WORLD_SIZE") && !std::getenv("PMIX_RANK") && !std::getenv("PMI_RANK"))
        setenv("OMPI_MCA_ess_singleton_isolated", "1", 0);
      int provided = 0;
      if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
        failure = "MPI_Init_thread failed";
        return;
      }
      own = true;
    }
    HYPRE_Init();
    if (own) std::atexit(finalize_mpi_at_exit);
  });
  if (!failure.empty()) throw SetupError(failure);
}

struct HypreAmgPcg::Impl {
  HYPRE_IJMatrix A = nullptr;
  HYPRE_IJVector b = nullptr, x = nullptr;
  HYPRE_ParCSRMatrix pA = nullptr;
  HYPRE_ParVector pb = nullptr, px = nullptr;
  HYPRE_Solver pcg = nullptr, amg = nullptr;
  HYPRE_BigInt n = 0;
  std::vector<HYPRE_BigInt> rows;
  bool ready = false;

  ~Impl() { clear(); }
  void clear() {
    ready = false;
    if (mpi_gone()) {  // at exit, after MPI_Finalize: leak rather than call into a finalised hypre
      pcg = amg = nullptr;
      A = nullptr;
      b = x = nullptr;
      return;
    }
    if (pcg) HYPRE_ParCSRPCGDestroy(pcg);
    if (amg) HYPRE_BoomerAMGDestroy(amg);
    if (A) HYPRE_IJMatrixDestroy(A);
    if (b) HYPRE_IJVectorDestroy(b);
    if (x) HYPRE_IJVectorDestroy(x);
    pcg = amg = nullptr;
    A = nullptr;
    b = x = nullptr;
  }
};

HypreAmgPcg::HypreAmgPcg() : HypreAmgPcg(Settings{}) {}
HypreAmgPcg::HypreAmgPcg(Settings s) : settings_(s), impl_(std::make_unique<Impl>()) {}
HypreAmgPcg::~HypreAmgPcg() = default;

bool HypreAmgPcg::ready() const { return impl_->ready; }

void HypreAmgPcg::setup(const Eigen::SparseMatrix<double>& M) {
  Impl& im = *impl_;
  im.clear();
  im.n = static_cast<HYPRE_BigInt>(M.rows());
  if (im.n == 0) { im.ready = true; return; }
  if (!M.isCompressed()) throw SetupError("HypreAmgPcg::setup: the matrix must be compressed");
  ensure_mpi();
  const HYPRE_BigInt last = im.n - 1;
  // The matrix is symmetric, so its compressed columns are its rows (CSR).
  std::vector<HYPRE_Int> ncols(static_cast<std::size_t>(im.n)), offd(static_cast<std::size_t>(im.n), 0);
  std::vector<HYPRE_BigInt> cols(static_cast<std::size_t>(M.nonZeros()));
  im.rows.resize(static_cast<std::size_t>(im.n));
  for (HYPRE_BigInt r = 0; r < im.n; ++r) {
    im.rows[r] = r;
    ncols[r] = static_cast<HYPRE_Int>(M.outerIndexPtr()[r + 1] - M.outerIndexPtr()[r]);
  }
  for (std::size_t k = 0; k < cols.size(); ++k) cols[k] = static_cast<HYPRE_BigInt>(M.innerIndexPtr()[k]);

  check(HYPRE_IJMatrixCreate(MPI_COMM_SELF, 0, last, 0, last, &im.A), "IJMatrixCreate");
  check(HYPRE_IJMatrixSetObjectType(im.A, HYPRE_PARCSR), "IJMatrixSetObjectType");
  check(HYPRE_IJMatrixSetDiagOffdSizes(im.A, ncols.data(), offd.data()), "IJMatrixSetDiagOffdSizes");
  check(HYPRE_IJMatrixInitialize(im.A), "IJMatrixInitialize");
  check(HYPRE_IJMatrixSetValues(im.A, static_cast<HYPRE_Int>(im.n), ncols.data(), im.rows.data(), cols.data(),
                                M.valuePtr()),
        "IJMatrixSetValues");
  check(HYPRE_IJMatrixAssemble(im.A), "IJMatrixAssemble");
  check(HYPRE_IJMatrixGetObject(im.A, reinterpret_cast<void**>(&im.pA)), "IJMatrixGetObject");
  for (HYPRE_IJVector* v : {&im.b, &im.x}) {
    check(HYPRE_IJVectorCreate(MPI_COMM_SELF, 0, last, v), "IJVectorCreate");
    check(HYPRE_IJVectorSetObjectType(*v, HYPRE_PARCSR), "IJVectorSetObjectType");
    check(HYPRE_IJVectorInitialize(*v), "IJVectorInitialize");
    check(HYPRE_IJVectorAssemble(*v), "IJVectorAssemble");
  }
  check(HYPRE_IJVectorGetObject(im.b, reinterpret_cast<void**>(&im.pb)), "IJVectorGetObject");
  check(HYPRE_IJVectorGetObject(im.x, reinterpret_cast<void**>(&im.px)), "IJVectorGetObject");

  // One V-cycle per PCG iteration. HMIS coarsening with extended+i interpolation (hypre's
  // defaults, set explicitly), forward/backward hybrid Gauss-Seidel down/up (13/14: a symmetric
  // cycle, as PCG needs), Gaussian elimination on the coarsest level.
  check(HYPRE_BoomerAMGCreate(&im.amg), "BoomerAMGCreate");
  HYPRE_BoomerAMGSetPrintLevel(im.amg, 0);
  HYPRE_BoomerAMGSetMaxIter(im.amg, 1);
  HYPRE_BoomerAMGSetTol(im.amg, 0.0);
  HYPRE_BoomerAMGSetCoarsenType(im.amg, 10);
  HYPRE_BoomerAMGSetInterpType(im.amg, 6);
  HYPRE_BoomerAMGSetPMaxElmts(im.amg, 4);
  HYPRE_BoomerAMGSetStrongThreshold(im.amg, settings_.strong_threshold);
  HYPRE_BoomerAMGSetCycleRelaxType(im.amg, 13, 1);
  HYPRE_BoomerAMGSetCycleRelaxType(im.amg, 14, 2);
  HYPRE_BoomerAMGSetCycleRelaxType(im.amg, 9, 3);
  if (settings_.aggressive_levels > 0) HYPRE_BoomerAMGSetAggNumLevels(im.amg, settings_.aggressive_levels);
  HYPRE_BoomerAMGSetKeepTranspose(im.amg, 1);  // store P^T: faster restriction, more memory

  check(HYPRE_ParCSRPCGCreate(MPI_COMM_SELF, &im.pcg), "ParCSRPCGCreate");
  HYPRE_PCGSetTwoNorm(im.pcg, 1);
  HYPRE_PCGSetPrintLevel(im.pcg, 0);
  HYPRE_PCGSetLogging(im.pcg, 1);
  check(HYPRE_ParCSRPCGSetPrecond(im.pcg, HYPRE_BoomerAMGSolve, HYPRE_BoomerAMGSetup, im.amg), "ParCSRPCGSetPrecond");
  check(HYPRE_ParCSRPCGSetup(im.pcg, im.pA, im.pb, im.px), "ParCSRPCGSetup (BoomerAMG setup)");
  im.ready = true;
}

HypreAmgPcg::Outcome HypreAmgPcg::solve(const Eigen::VectorXd& rhs, Eigen::VectorXd& x, double tol, int max_iterations) {
  Impl& im = *impl_;
  if (!im.ready) throw SetupError("HypreAmgPcg::solve before setup");
  if (rhs.size() != static_cast<Eigen::Index>(im.n) || x.size() != rhs.size())
    throw SetupError("HypreAmgPcg::solve: vector sizes do not match the matrix");
  Outcome out;
  if (im.n == 0) { out.converged = true; return out; }
  const auto n = static_cast<HYPRE_Int>(im.n);
  check(HYPRE_IJVectorSetValues(im.b, n, im.rows.data(), rhs.data()), "IJVectorSetValues");
  check(HYPRE_IJVectorSetValues(im.x, n, im.rows.data(), x.data()), "IJVectorSetValues");
  HYPRE_PCGSetTol(im.pcg, tol);
  HYPRE_PCGSetAbsoluteTol(im.pcg, 0.0);
  HYPRE_PCGSetMaxIter(im.pcg, max_iterations);
  // Non-convergence comes back as an error flag (HYPRE_ERROR_CONV): judged below, not thrown.
  HYPRE_ParCSRPCGSolve(im.pcg, im.pA, im.pb, im.px);
  HYPRE_ClearAllErrors();
  HYPRE_Int it = 0;
  HYPRE_Real rel = 0.0;
  HYPRE_PCGGetNumIterations(im.pcg, &it);
  HYPRE_PCGGetFinalRelativeResidualNorm(im.pcg, &rel);
  check(HYPRE_IJVectorGetValues(im.x, n, im.rows.data(), x.data()), "IJVectorGetValues");
  out.iterations = static_cast<int>(it);
  out.relative_residual = rel;
  out.converged = rel <= tol;
  return out;
}

}  // namespace sparkdem
