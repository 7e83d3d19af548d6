// Electric-network solvers: accuracy against run time (see benchmarks/README.md).
//
// For each network family and size, a reference solve (Direct when nodes <= 2e5, else Amg to a
// relative residual of 1e-13), then every method of LaplacianSolver at a range of tolerances (CG /
// Amg) or stopping thresholds beta (pseudo-transient). Each run uses a new (cold) solver, so its
// wall time includes the whole set-up (analysis, factorisation / preconditioner / AMG hierarchy /
// lambda_max). One CSV row per run.
//
// Usage: bench_electric [--sizes 1000,10000,100000] [--families packing,bonded,sintered]
//                       [--csv FILE] [--pt-budget SECONDS] [--seed N]
//
// Spread solves (issue 24 item 2): `mpirun -np N bench_electric --spread ...` runs the benchmark on
// rank 0, its reference on rank 0 alone, and every Amg solve spread over the N ranks
// (engine/graph/hypre_amg.hpp; method "amg_spread<N>"), the other ranks serving rank 0's commands.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/graph/hypre_amg.hpp"
#include "engine/graph/laplacian.hpp"

#include <mpi.h>
#include <thread>

using namespace sparkdem;

namespace {

struct Network {
  std::string family;
  std::size_t nodes = 0;
  std::vector<Index> a, b;
  std::vector<double> g, cap;
  std::vector<Index> high, low;
};

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  std::string t;
  while (std::getline(ss, t, ','))
    if (!t.empty()) out.push_back(t);
  return out;
}

/// Electrodes: centres in the lowest / highest 5 % of the z range (high = 1 V at the bottom).
void electrodes(Network& net, const std::vector<double>& z) {
  const auto [lo, hi] = std::minmax_element(z.begin(), z.end());
  const double z0 = *lo, h = *hi - *lo;
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (z[i] <= z0 + 0.05 * h)
      net.high.push_back(static_cast<Index>(i));
    else if (z[i] >= z0 + 0.95 * h)
      net.low.push_back(static_cast<Index>(i));
  }
}

/// Polydisperse overlap network: n sphere centres uniform in a cube, radii log-uniform on
/// [1, 15] (size ratio 15), an edge wherever two spheres overlap. The cube is sized for a mean
/// degree of about 6. Conductance: Holm-like g = 2 a kappa (kappa = 1) with the contact radius
/// a = sqrt(R* delta) of the overlap delta; "sintered": g log-uniform over 6 decades instead.
Network packing(std::size_t n, std::uint64_t seed, bool sintered) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double rmin = 1.0, ratio = 15.0;
  std::vector<double> r(n), x(n), y(n), z(n);
  double m1 = 0, m2 = 0, m3 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    r[i] = rmin * std::pow(ratio, u(rng));
    m1 += r[i];
    m2 += r[i] * r[i];
    m3 += r[i] * r[i] * r[i];
  }
  m1 /= n;
  m2 /= n;
  m3 /= n;
  // mean degree = n / L^3 * (4/3) pi E[(r_i + r_j)^3], E[(r_i + r_j)^3] = 2 m3 + 6 m2 m1
  const double degree = 6.0;
  const double L = std::cbrt(static_cast<double>(n) * 4.0 / 3.0 * M_PI * (2 * m3 + 6 * m2 * m1) / degree);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = L * u(rng);
    y[i] = L * u(rng);
    z[i] = L * u(rng);
  }
  // Cell list, cell side >= 2 rmax.
  const double cs = 2.0 * rmin * ratio;
  const int nc = std::max(1, static_cast<int>(L / cs));
  const double side = L / nc;
  auto cell = [&](double c) { return std::min(nc - 1, static_cast<int>(c / side)); };
  std::vector<std::vector<Index>> cells(static_cast<std::size_t>(nc) * nc * nc);
  auto cid = [&](int i, int j, int k) { return (static_cast<std::size_t>(i) * nc + j) * nc + k; };
  for (std::size_t i = 0; i < n; ++i) cells[cid(cell(x[i]), cell(y[i]), cell(z[i]))].push_back(static_cast<Index>(i));
  Network net;
  net.family = sintered ? "sintered" : "packing";
  net.nodes = n;
  for (std::size_t i = 0; i < n; ++i) {
    const int ci = cell(x[i]), cj = cell(y[i]), ck = cell(z[i]);
    for (int di = -1; di <= 1; ++di)
      for (int dj = -1; dj <= 1; ++dj)
        for (int dk = -1; dk <= 1; ++dk) {
          const int a = ci + di, b = cj + dj, c = ck + dk;
          if (a < 0 || b < 0 || c < 0 || a >= nc || b >= nc || c >= nc) continue;
          for (Index j : cells[cid(a, b, c)]) {
            if (static_cast<std::size_t>(j) <= i) continue;
            const double dx = x[i] - x[j], dy = y[i] - y[j], dz = z[i] - z[j];
            const double d = std::sqrt(dx * dx + dy * dy + dz * dz), s = r[i] + r[j];
            if (d >= s) continue;
            net.a.push_back(static_cast<Index>(i));
            net.b.push_back(j);
            const double rstar = r[i] * r[j] / s;
            net.g.push_back(2.0 * std::sqrt(rstar * (s - d)));
          }
        }
  }
  // Edge order from the cell walk is deterministic; sintered conductances drawn in that order.
  if (sintered)
    for (double& ge : net.g) ge = std::pow(10.0, 6.0 * u(rng) - 3.0);
  for (std::size_t i = 0; i < n; ++i) net.cap.push_back(r[i] * r[i] * r[i]);
  electrodes(net, z);
  return net;
}

/// Bonded continuum stand-in: k^3 nodes on a simple cubic lattice (spacing 1) jittered by up to
/// 0.1, 6-neighbour bonds with conductance uniform on [0.9, 1.1]; equal radii 0.5.
Network bonded(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int k = std::max(2, static_cast<int>(std::lround(std::cbrt(static_cast<double>(n)))));
  Network net;
  net.family = "bonded";
  net.nodes = static_cast<std::size_t>(k) * k * k;
  std::vector<double> z(net.nodes);
  auto id = [&](int i, int j, int l) { return static_cast<Index>((static_cast<std::size_t>(i) * k + j) * k + l); };
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j)
      for (int l = 0; l < k; ++l) {
        z[id(i, j, l)] = l + 0.2 * (u(rng) - 0.5);
        const int nb[3][3] = {{i + 1, j, l}, {i, j + 1, l}, {i, j, l + 1}};
        for (const auto& q : nb)
          if (q[0] < k && q[1] < k && q[2] < k) {
            net.a.push_back(id(i, j, l));
            net.b.push_back(id(q[0], q[1], q[2]));
            net.g.push_back(0.9 + 0.2 * u(rng));
          }
      }
  net.cap.assign(net.nodes, 0.125);
  electrodes(net, z);
  return net;
}

struct Run {
  std::string method, param, status = "ok";
  double wall = NAN, indicator = NAN, rel_residual = NAN, G = NAN, g_err = NAN, v_err = NAN;
  long iterations = -1;
  int ranks = 1;  ///< Amg: ranks the solve was spread over
  LaplacianResult res;
};

LaplacianProblem problem(const Network& net) {
  LaplacianProblem p;
  p.nodes = net.nodes;
  p.a = net.a;
  p.b = net.b;
  p.g = net.g;
  p.capacitance = net.cap;
  p.dirichlet = {{net.high, 1.0}, {net.low, 0.0}};
  return p;
}

Run run(const Network& net, const LaplacianOptions& opt, const std::string& param) {
  Run r;
  r.method = laplacian_method_name(opt.method);
  r.param = param;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    LaplacianSolver solver(opt);  // cold: set-up counted
    r.res = solver.solve(problem(net));
    r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    r.iterations = r.res.iterations;
    r.rel_residual = r.res.relative_residual;
    r.indicator = opt.method == LaplacianMethod::PseudoTransient ? r.res.pseudo.change_indicator : r.res.relative_residual;
    r.G = r.res.dirichlet_flux[0] / 1.0;
    r.ranks = r.res.amg_ranks;
  } catch (const std::exception& e) {
    r.wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string msg = e.what();
    r.status = msg.find("still above beta") != std::string::npos ? "capped" : "failed";
    // The pseudo-transient message carries the indicator at the cap: "change indicator X still above".
    const auto at = msg.find("change indicator ");
    if (at != std::string::npos) r.indicator = std::atof(msg.c_str() + at + 17);
    if (opt.method == LaplacianMethod::PseudoTransient && r.status == "capped") r.iterations = opt.max_iterations;
    if (r.status == "failed") std::cerr << "  " << r.method << " " << param << " failed: " << msg << "\n";
  }
  return r;
}

void score(Run& r, const LaplacianResult& ref, double G_ref) {
  if (r.status.rfind("ok", 0) != 0) return;
  r.g_err = std::abs(r.G - G_ref) / std::abs(G_ref);
  double m = 0.0;
  for (std::size_t v = 0; v < ref.value.size(); ++v)
    if (std::isfinite(ref.value[v])) m = std::max(m, std::abs(r.res.value[v] - ref.value[v]));  // / dV = 1
  r.v_err = m;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

/// --spread on a rank other than 0: carry out rank 0's solve commands until its stop (tag 99).
constexpr int kStopTag = 99;

}  // namespace

int bench_main(int argc, char** argv, int ranks);

int main(int argc, char** argv) {
  bool spread = false;
  for (int i = 1; i < argc; ++i) spread = spread || std::string(argv[i]) == "--spread";
  if (!spread) return bench_main(argc, argv, 1);
  int provided = 0, rank = 0, size = 1;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int rc = 0;
  if (rank == 0) {
    rc = bench_main(argc, argv, size);
    for (int r = 1; r < size; ++r) MPI_Send(nullptr, 0, MPI_CHAR, r, kStopTag, MPI_COMM_WORLD);
  } else {
    serve_amg_commands_until(kStopTag);
  }
  MPI_Finalize();
  return rc;
}

/// The reference solve: Direct (LDLT) up to 2e5 nodes, else CG with the Jacobi preconditioner to a
/// relative residual of 1e-13 (independent of the AMG being measured; on the 1e6-node packing network
/// it agrees with BoomerAMG-PCG at 1e-13 to 1.3e-11 in the potentials). On one process. With a
/// cache file, the potentials are read from it when it exists, else written to it after the solve
/// (the reference depends only on the family, the size and the seed).
Run reference(const Network& net, bool direct, const std::string& cache) {
  Run ref;
  if (!cache.empty()) {
    std::ifstream in(cache, std::ios::binary);
    if (in) {
      std::size_t free = 0;
      ref.method = laplacian_method_name(direct ? LaplacianMethod::Direct : LaplacianMethod::CgDiagonal);
      in.read(reinterpret_cast<char*>(&free), sizeof free);
      in.read(reinterpret_cast<char*>(&ref.G), sizeof ref.G);
      in.read(reinterpret_cast<char*>(&ref.wall), sizeof ref.wall);
      ref.res.value.resize(net.nodes);
      in.read(reinterpret_cast<char*>(ref.res.value.data()), static_cast<std::streamsize>(net.nodes * sizeof(double)));
      ref.res.free_nodes = free;
      if (in) {
        std::cerr << "  reference read from " << cache << "\n";
        return ref;
      }
      std::cerr << "  unreadable reference cache " << cache << ": solving\n";
    }
  }
  LaplacianOptions ro;
  ro.method = direct ? LaplacianMethod::Direct : LaplacianMethod::CgDiagonal;
  ro.tolerance = 1e-13;
  set_amg_spread_ranks(1);  // the reference on one process
  ref = run(net, ro, direct ? "" : "1e-13");
  if (ref.status == "ok" && !cache.empty()) {
    const std::string tmp = cache + ".tmp";
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(&ref.res.free_nodes), sizeof ref.res.free_nodes);
    out.write(reinterpret_cast<const char*>(&ref.G), sizeof ref.G);
    out.write(reinterpret_cast<const char*>(&ref.wall), sizeof ref.wall);
    out.write(reinterpret_cast<const char*>(ref.res.value.data()), static_cast<std::streamsize>(net.nodes * sizeof(double)));
    out.close();
    if (out) std::rename(tmp.c_str(), cache.c_str());
  }
  return ref;
}

int bench_main(int argc, char** argv, int ranks) {
  std::vector<std::size_t> sizes = {1000, 10000, 100000};
  std::vector<std::string> families = {"packing", "bonded", "sintered"};
  std::string csv = "results.csv";
  double pt_budget = 30.0;
  std::uint64_t seed = 12345;
  std::vector<std::string> solvers = {"cg_ic", "cg_jacobi", "amg", "pseudo_transient"};
  std::vector<double> tols = {1e-4, 1e-6, 1e-8, 1e-10};
  LaplacianOptions amg_defaults;
  std::string ref_cache;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << a << " needs a value\n";
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--sizes") {
      sizes.clear();
      for (auto& s : split(next())) sizes.push_back(static_cast<std::size_t>(std::stod(s)));
    } else if (a == "--families")
      families = split(next());
    else if (a == "--csv")
      csv = next();
    else if (a == "--pt-budget")
      pt_budget = std::stod(next());
    else if (a == "--seed")
      seed = std::stoull(next());
    else if (a == "--solvers")
      solvers = split(next());
    else if (a == "--tolerances") {
      tols.clear();
      for (auto& s : split(next())) tols.push_back(std::stod(s));
    } else if (a == "--amg-threshold")
      amg_defaults.amg_strong_threshold = std::stod(next());
    else if (a == "--amg-aggressive")
      amg_defaults.amg_aggressive_levels = std::stoi(next());
    else if (a == "--amg-eliminate")
      amg_defaults.amg_eliminate_low_degree = std::stoi(next()) != 0;
    else if (a == "--reference-cache")
      ref_cache = next();
    else if (a == "--spread")
      continue;
    else {
      std::cerr << "usage: bench_electric [--sizes N,..] [--families packing,bonded,sintered] [--csv FILE] [--pt-budget S]"
                   " [--seed N] [--solvers cg_ic,cg_jacobi,amg,pseudo_transient] [--tolerances 1e-4,..]"
                   " [--amg-threshold X] [--amg-aggressive L] [--amg-eliminate 0|1] [--reference-cache DIR]\n";
      return 2;
    }
  }
  std::ofstream out(csv);
  if (!out) {
    std::cerr << "cannot write " << csv << "\n";
    return 1;
  }
  out << "family,nodes,edges,free_nodes,reference,method,tolerance_or_beta,status,wall_s,iterations,indicator,"
         "relative_residual,G,G_rel_err,V_max_err\n";
  // Warm-up: the first hypre call in a process initialises MPI/hypre (~0.2 s); keep it out of the
  // first timed Amg run.
  {
    LaplacianOptions o;
    o.method = LaplacianMethod::Amg;
    (void)run(bonded(1000, 1), o, "warm-up");
  }
  const double betas[] = {1e-2, 1e-3, 2e-4, 1e-5};
  for (const auto& fam : families) {
    for (std::size_t n : sizes) {
      Network net;
      if (fam == "packing")
        net = packing(n, seed + n, false);
      else if (fam == "sintered")
        net = packing(n, seed + n, true);
      else if (fam == "bonded")
        net = bonded(n, seed + n);
      else {
        std::cerr << "unknown family " << fam << "\n";
        return 2;
      }
      std::cerr << fam << " n=" << net.nodes << " edges=" << net.a.size() << " electrodes " << net.high.size() << "/" << net.low.size()
                << std::endl;
      std::vector<Run> rows;
      // Reference.
      const bool direct_ref = net.nodes <= 200000;
      const std::string ref_file =
          ref_cache.empty() ? "" : ref_cache + "/ref_" + fam + "_" + std::to_string(net.nodes) + "_" + std::to_string(seed) + ".bin";
      Run ref = reference(net, direct_ref, ref_file);
      set_amg_spread_ranks(ranks);
      if (ref.status != "ok") {
        std::cerr << "reference failed\n";
        return 1;
      }
      const double G_ref = ref.G;
      std::cerr << "  reference " << ref.method << " " << ref.wall << " s, G = " << G_ref << std::endl;
      if (direct_ref) {
        ref.status = "ok(reference)";
        rows.push_back(ref);
      }
      const auto wanted = [&](LaplacianMethod m) {
        return std::find(solvers.begin(), solvers.end(), laplacian_method_name(m)) != solvers.end();
      };
      // Warm-up on this network: the first large solve of a process pays for faulting in its
      // memory (1e6 nodes: 3.2 s against 2.5-2.8 s for the next ones), which a reference solved
      // in the same process used to pay; with a cached reference nothing did.
      if (wanted(LaplacianMethod::Amg) && net.nodes > 200000) {
        LaplacianOptions o = amg_defaults;
        o.method = LaplacianMethod::Amg;
        o.tolerance = 1e-2;
        (void)run(net, o, "warm-up");
      }
      for (auto m : {LaplacianMethod::CgIncompleteCholesky, LaplacianMethod::CgDiagonal, LaplacianMethod::Amg})
        for (double t : tols) {
          if (!wanted(m)) continue;
          LaplacianOptions o = amg_defaults;
          o.method = m;
          o.tolerance = t;
          rows.push_back(run(net, o, num(t)));
          if (m == LaplacianMethod::Amg && ranks > 1) rows.back().method = "amg_spread" + std::to_string(rows.back().ranks);
          std::cerr << "  " << rows.back().method << " " << t << " " << rows.back().wall << " s" << std::endl;
        }
      // Pseudo-transient: iteration cap from a 50-iteration calibration run, so that one run
      // takes about pt_budget seconds at most. A beta below a capped one is capped too: skipped.
      if (wanted(LaplacianMethod::PseudoTransient)) {
        LaplacianOptions o;
        o.method = LaplacianMethod::PseudoTransient;
        o.pseudo.indicator = ChangeIndicator::Range;
        o.pseudo.dt_fraction = 0.9;
        o.pseudo.beta = 1e-300;
        o.max_iterations = 50;
        const Run cal = run(net, o, "calibration");
        const double per_it = cal.wall / 50.0;  // includes the lambda_max set-up: an over-estimate
        const int cap = static_cast<int>(std::clamp(pt_budget / per_it, 100.0, 1e6));
        bool capped = false;
        for (double beta : betas) {
          o.pseudo.beta = beta;
          o.max_iterations = cap;
          Run r;
          if (capped) {
            r.method = laplacian_method_name(o.method);
            r.param = num(beta);
            r.status = "capped(skipped)";
            r.iterations = cap;
          } else {
            r = run(net, o, num(beta));
            capped = r.status == "capped";
          }
          std::cerr << "  pt beta " << beta << " " << r.status << " " << r.wall << " s, it " << r.iterations << std::endl;
          rows.push_back(std::move(r));
        }
      }
      for (auto& r : rows) {
        score(r, ref.res, G_ref);
        out << fam << ',' << net.nodes << ',' << net.a.size() << ',' << ref.res.free_nodes << ',' << (direct_ref ? "direct" : "cg_jacobi@1e-13")
            << ',' << r.method << ',' << r.param << ',' << r.status << ',' << num(r.wall) << ',' << r.iterations << ',' << num(r.indicator)
            << ',' << num(r.rel_residual) << ',' << num(r.G) << ',' << num(r.g_err) << ',' << num(r.v_err) << '\n';
        r.res = LaplacianResult{};
      }
      out.flush();
    }
  }
  return 0;
}
