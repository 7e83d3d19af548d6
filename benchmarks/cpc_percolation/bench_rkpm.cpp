// Convergence checks of the RKPM continuum matrix (physics/electrical/rkpm_matrix.*), seed 002.
//
//   bench_rkpm single   rigid sphere (a = 1) in a matrix ball (b = 3): field error against the
//                       closed form vs node spacing, alpha = 1 and 100 (E = 1, nu = 0.35)
//   bench_rkpm two      the paper's convergence test: two touching spheres of radius 0.1 at the
//                       centre of a unit cube (or a ball of radius 0.5: RKPM_DOMAIN=ball), eps0 =
//                       1 %, alpha = 100 E, E = 1: change of the centre distance vs node count
//                       (paper: converged above ~7000 nodes); options in the environment (two())
// Output: one CSV line per resolution on stdout (header first).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include <random>

#include "physics/electrical/ptc_matrix.hpp"
#include "physics/electrical/rkpm_matrix.hpp"
#include "physics/packing/cpc_fillers.hpp"

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

void single(double nu, const std::vector<double>& spacings, int order, int sub) {
  const double a = 1.0, b = 3.0;
  std::printf(
      "alpha,h,nodes,unknowns,nonzeros,iterations,residual,U_norm,max_err_over_B,A,B,quad_volume,exact_volume,assembly_s,solve_s\n");
  for (double alpha : {1.0, 100.0})
    for (double h : spacings) {
      rkpm::Params p;
      p.poisson_ratio = nu;
      p.node_spacing = h;
      p.bond_penalty = alpha;
      p.surface_points = 64;
      p.quadrature_order = order;
      p.cell_subdivision = sub;
      p.cg_tolerance = 1e-12;
      if (const char* sv = std::getenv("RKPM_SOLVER")) p.solver = sv;
      rkpm::Domain d;
      d.lo = Vec3(-b, -b, -b);
      d.hi = Vec3(b, b, b);
      d.ball_radius = b;
      const rkpm::Result r = rkpm::solve_unit({Vec3(0, 0, 0)}, {a}, d, p);
      const auto [A, B] = rkpm::single_sphere_closed_form(a, b, 1.0, nu, alpha);
      double err = 0.0;
      const double radii[] = {1.0, 1.25, 1.5, 2.0, 2.5, 3.0};
      double per[6] = {0, 0, 0, 0, 0, 0};
      for (const Vec3& e : rkpm::sphere_points(16))
        for (int k = 0; k < 6; ++k) {
          const double rr = radii[k];
          const double ur = r.displacement(rr * a * e).dot(e);
          per[k] = std::max(per[k], std::abs(ur - (A * rr + B / (rr * rr))) / std::abs(B / (a * a)));
          if (k > 0) err = std::max(err, std::abs(ur - (A * rr + B / (rr * rr))));
        }
      std::fprintf(stderr, "  per radius (1, 1.25, 1.5, 2, 2.5, 3): %.4f %.4f %.4f %.4f %.4f %.4f\n", per[0], per[1], per[2], per[3],
                   per[4], per[5]);
      std::printf("%g,%g,%zu,%zu,%zu,%d,%.3e,%.3e,%.5f,%.6f,%.6f,%.5f,%.5f,%.2f,%.2f\n", alpha, h, r.approximation.nodes(), r.unknowns,
                  r.nonzeros, r.iterations, r.residual, r.sphere_displacement[0].norm(), err / std::abs(B / (a * a)), A, B,
                  r.quadrature_volume, 4.0 / 3.0 * M_PI * (b * b * b - a * a * a), r.assembly_seconds, r.solve_seconds);
      std::fflush(stdout);
    }
}

/// Options of `two` from the environment: RKPM_DOMAIN cube | ball (ball: radius
/// RKPM_BALL_RADIUS, default 0.5, centred in the unit cube: the matrix ball of
/// tools/two_sphere_reference.py with b / R = 5), RKPM_ALPHA_R_OVER_E (10: the paper's alpha = 100 E
/// with R = 0.1), RKPM_DEPTH (cut_cell_depth), RKPM_SURFACE_SPACING, RKPM_NODES (comma-separated
/// nodes per edge of the domain's bounding cube), RKPM_SUPPORT (support_factor).
double env_or(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v ? std::atof(v) : fallback;
}

void two(double nu, std::vector<int> per_edge, int order, int sub) {
  const double R = 0.1, eps0 = 0.01;
  const char* dom = std::getenv("RKPM_DOMAIN");
  const bool ball = dom && !std::strcmp(dom, "ball");
  if (const char* nodes = std::getenv("RKPM_NODES")) {
    per_edge.clear();
    for (const char* q = nodes; *q;) {
      per_edge.push_back(std::atoi(q));
      while (*q && *q != ',') ++q;
      if (*q == ',') ++q;
    }
  }
  std::printf(
      "domain,b_over_R,alpha_R_over_E,nu,depth,nodes_per_edge,h_over_R,nodes,unknowns,nonzeros,volume_points,surface_points,quad_volume,"
      "exact_volume,iterations,residual,distance_change_over_eps0_D,assembly_s,solve_s\n");
  for (int m : per_edge) {
    rkpm::Params p;
    p.poisson_ratio = nu;
    const double b = ball ? env_or("RKPM_BALL_RADIUS", 0.5) : 0.5;
    p.node_spacing = 2.0 * b / (m - 1);
    p.bond_penalty = env_or("RKPM_ALPHA_R_OVER_E", 10.0) / R;
    p.quadrature_order = order;
    p.cell_subdivision = sub;
    p.cut_cell_depth = static_cast<int>(env_or("RKPM_DEPTH", 2));
    p.surface_spacing = env_or("RKPM_SURFACE_SPACING", 0.5);
    p.support_factor = env_or("RKPM_SUPPORT", 2.0);
    if (const char* sv = std::getenv("RKPM_SOLVER")) p.solver = sv;
    rkpm::Domain d;
    d.lo = Vec3(0, 0, 0);
    d.hi = Vec3(1, 1, 1);
    if (ball) {
      d.lo = Vec3::Constant(0.5 - b);
      d.hi = Vec3::Constant(0.5 + b);
      d.ball_radius = b;
    }
    const rkpm::Result r = rkpm::solve_unit({Vec3(0.5 - R, 0.5, 0.5), Vec3(0.5 + R, 0.5, 0.5)}, {R, R}, d, p);
    const double dd = eps0 * (r.sphere_displacement[1] - r.sphere_displacement[0]).x();
    const double outer = ball ? 4.0 / 3.0 * M_PI * b * b * b : 1.0;
    std::printf("%s,%g,%g,%g,%d,%d,%.4f,%zu,%zu,%zu,%zu,%zu,%.6f,%.6f,%d,%.3e,%.6f,%.2f,%.2f\n", ball ? "ball" : "cube", ball ? b / R : 5.0,
                p.bond_penalty * R, nu, p.cut_cell_depth, m, p.node_spacing / R, r.approximation.nodes(), r.unknowns, r.nonzeros,
                r.volume_points, r.surface_points, r.quadrature_volume, outer - 2.0 * 4.0 / 3.0 * M_PI * R * R * R, r.iterations,
                r.residual, dd / (eps0 * 2 * R), r.assembly_seconds, r.solve_seconds);
    std::fflush(stdout);
  }
}

/// A cpc_fillers-like configuration (own RNG: not the scenario's configurations) in an L box at
/// phi = 25 %, then the RKPM solve and the bonded solve: opening statistics and timing.
void box(double L, double h, double support, int order, int sub, double nu, double lambda) {
  const double R = 1.0, phi = 0.25;
  const auto n = static_cast<std::size_t>(std::round(phi * L * L * L / (4.0 / 3.0 * M_PI)));
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0.0, L);
  std::vector<Vec3> x(n);
  for (auto& p : x) p = Vec3(u(rng), u(rng), u(rng));
  const std::vector<double> r(n, R);
  cpc::remove_overlaps(x, r, 0.4, 1e-3, 1000000);
  if (lambda > 0.0) {
    cpc::aggregate(x, r, lambda, 1e-3, rng);
    cpc::remove_overlaps(x, r, 0.4, 1e-3, 1000000);
  }
  rkpm::Params p;
  p.node_spacing = h;
  p.support_factor = support;
  p.quadrature_order = order;
  p.cell_subdivision = sub;
  p.poisson_ratio = nu;
  p.cut_cell_depth = static_cast<int>(env_or("RKPM_DEPTH", 2));
  if (const char* sv = std::getenv("RKPM_SOLVER")) p.solver = sv;
  p.amg_strong_threshold = env_or("RKPM_AMG_THETA", 0.5);
  rkpm::Domain d;  // the smallest cube holding [0, L]^3 and every filler (as ptc_strain)
  Vec3 lo = Vec3::Zero(), hi = Vec3::Constant(L);
  for (std::size_t i = 0; i < n; ++i) {
    lo = lo.cwiseMin(x[i] - Vec3::Constant(r[i]));
    hi = hi.cwiseMax(x[i] + Vec3::Constant(r[i]));
  }
  d.lo = lo;
  d.hi = lo + Vec3::Constant((hi - lo).maxCoeff());
  const rkpm::Result res = rkpm::solve_unit(x, r, d, p);
  ptc::MatrixParams mp;
  mp.min_gap_rel = 0.1 / (2 * R);  // h_min = 0.1 R, h_max = 1 R
  mp.cutoff_gap_rel = 1.0 / (2 * R);
  const ptc::SpringNetwork net = ptc::build_network(x, r, mp);
  const ptc::UnitSolution sb = ptc::solve_unit(n, net, mp);
  double mr = 0.0, mb = 0.0;
  std::size_t nc = 0, negr = 0, negb = 0;
  for (std::size_t e = 0; e < net.size(); ++e)
    if (net.gap[e] <= 1e-3 * net.distance[e]) {
      const double o = net.normal[e].dot(res.sphere_displacement[net.b[e]] - res.sphere_displacement[net.a[e]]) / (2 * R);
      mr += o;
      mb += sb.opening[e] / (2 * R);
      negr += o < 0;
      negb += sb.opening[e] < 0;
      ++nc;
    }
  std::printf(
      "depth %d points %zu L %g n %zu h %g nodes %zu unknowns %zu nnz %zu CG %d residual %.2e vol %.1f (box %.1f, spheres %.1f) assembly "
      "%.1f s solve %.1f s\n",
      p.cut_cell_depth, res.volume_points, L, n, h, res.approximation.nodes(), res.unknowns, res.nonzeros, res.iterations, res.residual,
      res.quadrature_volume, L * L * L, n * 4.0 / 3.0 * M_PI, res.assembly_seconds, res.solve_seconds);
  std::printf("contacts %zu: mean unit opening / D rkpm %.5f (negative %.3f) bonded %.5f (negative %.3f)\n", nc, mr / nc, double(negr) / nc,
              mb / nc, double(negb) / nc);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: bench_rkpm single|two|box [nu] [order] [subdivision] [L h support lambda (box)]\n");
    return 2;
  }
  const double nu = argc > 2 ? std::atof(argv[2]) : 0.35;
  const int order = argc > 3 ? std::atoi(argv[3]) : 2;
  const int sub = argc > 4 ? std::atoi(argv[4]) : 2;
  try {
    if (!std::strcmp(argv[1], "single"))
      single(nu, {0.75, 0.5, 0.375, 0.3}, order, sub);
    else if (!std::strcmp(argv[1], "two"))
      two(nu, {8, 11, 14, 17, 20, 23, 26}, order, sub);
    else if (!std::strcmp(argv[1], "box"))
      box(argc > 5 ? std::atof(argv[5]) : 20.0, argc > 6 ? std::atof(argv[6]) : 3.0, argc > 7 ? std::atof(argv[7]) : 2.0, order, sub, nu,
          argc > 8 ? std::atof(argv[8]) : 0.0);
    else {
      std::fprintf(stderr, "unknown mode %s\n", argv[1]);
      return 2;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
