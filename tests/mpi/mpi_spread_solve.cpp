// Spread network solves (issue 24 item 2; engine/graph/hypre_amg.hpp), run by
// tests/mpi/test_mpi_sweeps.py under `mpirun -np 2`: on rank 0, a 30 x 30 x 30 lattice network
// (27,000 nodes, conductances spread over three decades, 1 V between the z faces) solved by Amg
// on rank 0 alone and spread over the 2 ranks (spread threshold lowered to 1000 rows), both
// against the direct solve (Eigen's LDL^T, independent of hypre): every node potential within
// 1e-7 V and the conductance within 1e-7 relative, for a first solve and a second one with other
// electrode values on the kept hierarchy; the spread solver reports 2 ranks. Rank 1 serves rank
// 0's commands until its stop message. Exit code 0 when every check holds.
#include <mpi.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "engine/graph/hypre_amg.hpp"
#include "engine/graph/laplacian.hpp"

using namespace sparkdem;

namespace {

constexpr int kStopTag = 99;
int failures = 0;

void check(bool ok, const std::string& what) {
  std::printf("%s  %s\n", ok ? "ok  " : "FAIL", what.c_str());
  failures += ok ? 0 : 1;
}

struct Lattice {
  std::size_t nodes = 0;
  std::vector<Index> a, b, top, bottom;
  std::vector<double> g;
};

Lattice lattice(int n) {
  Lattice L;
  L.nodes = static_cast<std::size_t>(n) * n * n;
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> u(0.0, 3.0);
  auto id = [n](int i, int j, int k) { return static_cast<Index>((k * n + j) * n + i); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const int d[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
        for (const auto& e : d) {
          if (i + e[0] >= n || j + e[1] >= n || k + e[2] >= n) continue;
          L.a.push_back(id(i, j, k));
          L.b.push_back(id(i + e[0], j + e[1], k + e[2]));
          L.g.push_back(std::pow(10.0, u(rng)));  // 1 ... 1000 S
        }
        if (k == 0) L.bottom.push_back(id(i, j, k));
        if (k == n - 1) L.top.push_back(id(i, j, k));
      }
  return L;
}

LaplacianResult solve(LaplacianSolver& s, const Lattice& L, double v_top) {
  LaplacianProblem p;
  p.nodes = L.nodes;
  p.a = L.a;
  p.b = L.b;
  p.g = L.g;
  p.dirichlet = {{L.top, v_top}, {L.bottom, 0.0}};
  return s.solve(p);
}

void compare(const LaplacianResult& r, const LaplacianResult& ref, double v_top, const std::string& what) {
  double worst = 0.0;
  for (std::size_t v = 0; v < ref.value.size(); ++v) worst = std::max(worst, std::abs(r.value[v] - ref.value[v]));
  const double g = r.dirichlet_flux[0] / v_top, g_ref = ref.dirichlet_flux[0] / v_top;
  char buf[256];
  std::snprintf(buf, sizeof buf, "%s: max |V - V_direct| = %.3g V (<= 1e-7), |G/G_direct - 1| = %.3g (<= 1e-7), %d iterations",
                what.c_str(), worst, std::abs(g / g_ref - 1.0), r.iterations);
  check(worst <= 1e-7 * v_top && std::abs(g / g_ref - 1.0) <= 1e-7, buf);
}

int rank0(int ranks) {
  const Lattice L = lattice(30);
  LaplacianSolver direct;
  LaplacianOptions amg;
  amg.method = LaplacianMethod::Amg;
  amg.tolerance = 1e-12;
  amg.amg_spread_min_rows = 1000;
  for (double v_top : {1.0, 2.5}) {
    const LaplacianResult ref = solve(direct, L, v_top);
    set_amg_spread_ranks(1);
    LaplacianSolver alone(amg);
    const LaplacianResult r1 = solve(alone, L, v_top);
    check(r1.amg_ranks == 1, "rank 0 alone: amg_ranks = 1");
    compare(r1, ref, v_top, "Amg on rank 0 alone, V_top = " + std::to_string(v_top));
    set_amg_spread_ranks(ranks);
    static LaplacianSolver spread(amg);  // kept: the second solve reuses its hierarchy
    const LaplacianResult r2 = solve(spread, L, v_top);
    check(r2.amg_ranks == ranks, "spread: amg_ranks = " + std::to_string(r2.amg_ranks) + " (expected " + std::to_string(ranks) + ")");
    compare(r2, ref, v_top, "Amg spread over " + std::to_string(ranks) + " ranks, V_top = " + std::to_string(v_top));
    if (v_top != 1.0) check(!r2.factorized, "second spread solve reuses the hierarchy (same matrix)");
  }
  return failures == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  int provided = 0, rank = 0, size = 1;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int rc = 0;
  if (rank == 0) {
    rc = size > 1 ? rank0(size) : (std::printf("FAIL  needs 2 or more ranks\n"), 1);
    for (int r = 1; r < size; ++r) MPI_Send(nullptr, 0, MPI_CHAR, r, kStopTag, MPI_COMM_WORLD);
  } else {
    serve_amg_commands_until(kStopTag);
  }
  MPI_Finalize();
  return rc;
}
