// Issue 59 item 3: what one linear solve of the inertia-free hot press costs as the compact grows.
//
// Reads a system K x = b of solve_quasi_static (the first round of one substep, scaled and
// regularised as the engine solves it: K's lower triangle and b in Matrix Market files PREFIX_K.mtx
// and PREFIX_b.mtx) and times, on one thread:
//   simplicial  Eigen's SimplicialLDLT (the engine's direct solver): analyse, factorise, one solve
//   cholmod     CHOLMOD's supernodal LL^T through Eigen (Debian libsuitesparse-dev, OpenBLAS)
//   ic          conjugate gradients with incomplete Cholesky (the engine's "cg" solver), to 1e-10
//   jacobi      conjugate gradients with the diagonal, to 1e-10
// and prints one CSV row per solver: unknowns, nonzeros, seconds and the relative residual.
//
// The systems: the 6th call of solve_quasi_static in the hot press of
// benchmarks/sps_nial/uniformity_mechanism.py's scene (configs/sps_nial_small.json with the
// quasi-static press, seed 2024) at size 1, 4 and 15 (300, 1162, 4493 particles), written by a
// temporary Eigen::saveMarket after regularise_and_scale (not in the engine). Not built by CMake
// (CHOLMOD is not a dependency); build and run:
//   g++ -O2 -std=c++20 -I/usr/include/eigen3 -I/usr/include/suitesparse qs_solver_scaling.cpp \
//       -o qs_solver_scaling -lcholmod -lsuitesparseconfig
//   OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 ./qs_solver_scaling PREFIX [particles]
#include <Eigen/CholmodSupport>
#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <chrono>
#include <cstdio>
#include <string>
#include <unsupported/Eigen/SparseExtra>

using SpMat = Eigen::SparseMatrix<double>;

static double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: qs_solver_scaling PREFIX [particles]\n");
    return 2;
  }
  SpMat K;
  Eigen::VectorXd b;
  if (!Eigen::loadMarket(K, std::string(argv[1]) + "_K.mtx") || !Eigen::loadMarketVector(b, std::string(argv[1]) + "_b.mtx")) {
    std::fprintf(stderr, "cannot read %s_K.mtx / _b.mtx\n", argv[1]);
    return 2;
  }
  const char* particles = argc > 2 ? argv[2] : "";
  const SpMat full = K.selfadjointView<Eigen::Lower>();
  auto residual = [&](const Eigen::VectorXd& x) { return (full * x - b).norm() / b.norm(); };
  auto row = [&](const char* solver, double analyse, double factor, double solve, double res, long it) {
    std::printf("%s,%ld,%ld,%s,%.4g,%.4g,%.4g,%ld,%.3g\n", particles, static_cast<long>(K.rows()), static_cast<long>(K.nonZeros()), solver,
                analyse, factor, solve, it, res);
  };
  std::printf("particles,unknowns,nonzeros_lower,solver,analyse_s,factorise_s,solve_s,iterations,relative_residual\n");
  // A direct solver: analyse, factorise and one solve, each timed.
  auto direct = [&](auto& s, const char* name) {
    const double t0 = now();
    s.analyzePattern(K);
    const double t1 = now();
    s.factorize(K);
    const double t2 = now();
    const Eigen::VectorXd x = s.solve(b);
    row(name, t1 - t0, t2 - t1, now() - t2, residual(x), 0);
  };
  {
    Eigen::SimplicialLDLT<SpMat, Eigen::Lower> s;
    direct(s, "simplicial_ldlt");
  }
  {
    Eigen::CholmodSupernodalLLT<SpMat, Eigen::Lower> s;
    direct(s, "cholmod_supernodal_llt");
  }
  {
    Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper, Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>> cg;
    cg.setTolerance(1e-10);
    cg.setMaxIterations(20000);
    const double t0 = now();
    cg.compute(full);
    const double t1 = now();
    const Eigen::VectorXd x = cg.solve(b);
    row("cg_incomplete_cholesky", 0.0, t1 - t0, now() - t1, residual(x), static_cast<long>(cg.iterations()));
  }
  {
    Eigen::ConjugateGradient<SpMat, Eigen::Lower | Eigen::Upper> cg;
    cg.setTolerance(1e-10);
    cg.setMaxIterations(200000);
    cg.compute(full);
    const double t0 = now();
    const Eigen::VectorXd x = cg.solve(b);
    row("cg_jacobi", 0.0, 0.0, now() - t0, residual(x), static_cast<long>(cg.iterations()));
  }
  return 0;
}
