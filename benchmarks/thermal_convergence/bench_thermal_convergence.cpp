/// Time-step convergence of heat_conduction's explicit (forward Euler) and implicit (backward
/// Euler) schemes (issue 6, "Stability"):
///
///   bench_thermal_convergence [--out DIR] [--quick]
///
/// writes DIR/results.csv and DIR/results.md (DIR defaults to the current directory).
///
/// Problems (frozen packings, so the network is constant and the reference is exact):
///   stiff  the stiff scene of tests/support/thermal_network.hpp (four 1 mm steel spheres, one
///          10 um sphere pressed against the first, an insulating inclusion: branch contrast
///          1e8); L0 starts at 500 K, the rest at 300 K; t_end = 20,000 explicit stable steps
///          (3.155 s). Reference: the modal solution exp(-C^-1 L t) T0 (exact to round-off).
///   chain  a straight chain of 101 steel spheres (r = 50 um, overlap 0.1 um, transmission
///          surface S = 4 r^2) held at 300 K at both ends and heated uniformly by the current
///          of electrical_network (0.05 V end to end); t_end = 2,000 explicit stable steps
///          (1.24 s, about one slowest relaxation time). Reference: T_ss + exp(-C^-1 L t)
///          (T0 - T_ss) on the free nodes, T_ss the discrete steady state (the parabola).
/// Steps: explicit at 1, 0.5, 0.25, 0.1 x its stable step (0.9 x the Gershgorin bound; fixed
/// every_step clock), implicit at 1, 10, 100, 1000 x that step. Error: the largest |T - T_ref|
/// over the large spheres (stiff) or all nodes (chain) at t_end [K]; observed order
/// log(e_k / e_k+1) / log(dt_k / dt_k+1) between successive rows of a scheme. Wall time: the
/// stage's run time (one thread).
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/electrical/electrical_network.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/thermal_network.hpp"

namespace {
using namespace sparkdem;
using namespace sparkdem::physics;
using test::StiffScene;
namespace fs = std::filesystem;

struct Row {
  std::string problem, scheme;
  double factor = 0.0;  ///< dt / explicit stable step
  double dt = 0.0, t_end = 0.0;
  long long steps = 0;
  double error = 0.0, ref_excursion = 0.0, order = NAN, wall = 0.0;
};

/// Build the contact table (a zero-step stage), then run n frozen steps of dt; the wall time of
/// the n steps [s].
double timed_run(Simulation& sim, double dt, Step n) {
  test::NullObserver obs;
  sim.run_stage(test::frozen_stage(dt, 0), obs);
  const auto t0 = std::chrono::steady_clock::now();
  sim.run_stage(test::frozen_stage(dt, n), obs);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ---------------------------------------------------------------------------------- stiff
Row run_stiff(const std::string& scheme, double factor, double s_exp, double t_end) {
  State s;
  StiffScene::build(s);
  HeatConduction heat(test::StiffScene::heat_params(scheme));
  Clock one;
  one.kind = Clock::Kind::EveryStep;
  heat.set_clock(one);
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&heat);
  const double dt = factor * s_exp * (scheme == "explicit" ? 1.0 - 1e-12 : 1.0);
  const Step n = static_cast<Step>(std::llround(t_end / (factor * s_exp)));
  const double wall = timed_run(sim, dt, n);
  const test::ModalSolution modal(StiffScene::laplacian(), StiffScene::capacities());
  const Eigen::VectorXd ref = modal.exact(StiffScene::initial(), static_cast<double>(n) * dt);
  const auto& T = s.particles.fields.data("temperature");
  Row r{"stiff", scheme, factor, dt, static_cast<double>(n) * dt, n};
  for (int i : {StiffScene::L0, StiffScene::L1, StiffScene::L2}) r.error = std::max(r.error, std::abs(T[i] - ref[i]));
  r.ref_excursion = 200.0;
  r.wall = wall;
  return r;
}

// ---------------------------------------------------------------------------------- chain
constexpr int kChainN = 101;
constexpr double kRc = 5e-5, kOverlap = 1e-7, kRho = 7900.0, kCp = 500.0, kLambda = 15.0, kRhoE = 0.73e-6, kVolt = 0.05;

void build_chain(State& s) {
  const double l = 2 * kRc - kOverlap;
  for (int k = 0; k < kChainN; ++k) test::add_sphere(s, Vec3(0, 0, k * l), kRc, kRho);
  s.particles.fields.declare({"temperature", 1, "K", 0.0, true}, s.particles.size());
  s.particles.fields.data("temperature") = std::vector<double>(kChainN, 300.0);
  auto ids = [&](const std::string& name, std::vector<Id> v) {
    SetSelector sel;
    sel.kind = SetSelector::Kind::Ids;
    sel.ids = std::move(v);
    assign_set(s, name, sel);
  };
  ids("ends", {0, kChainN - 1});
  ids("first", {0});
  ids("last", {kChainN - 1});
}

/// Reference temperatures of the chain at t (free nodes 1..N-2; ends at 300 K).
Eigen::VectorXd chain_reference(double t) {
  const double l = 2 * kRc - kOverlap, S = 4 * kRc * kRc;
  const double G = kLambda * S / l, Rb = kRhoE * l / S, I = kVolt / ((kChainN - 1) * Rb), P = I * I * Rb;
  const int m = kChainN - 2;
  Eigen::MatrixXd L = Eigen::MatrixXd::Zero(m, m);
  for (int i = 0; i < m; ++i) {
    L(i, i) = 2 * G;
    if (i > 0) L(i, i - 1) = -G;
    if (i + 1 < m) L(i, i + 1) = -G;
  }
  const Eigen::VectorXd C = Eigen::VectorXd::Constant(m, kRho * kCp * 4.0 / 3.0 * M_PI * kRc * kRc * kRc);
  Eigen::VectorXd b = Eigen::VectorXd::Constant(m, P);
  b[0] += G * 300.0;
  b[m - 1] += G * 300.0;
  const Eigen::VectorXd Tss = L.ldlt().solve(b);
  const test::ModalSolution modal(L, C);
  const Eigen::VectorXd free = Tss + modal.exact(Eigen::VectorXd::Constant(m, 300.0) - Tss, t);
  Eigen::VectorXd out(kChainN);
  out[0] = out[kChainN - 1] = 300.0;
  out.segment(1, m) = free;
  return out;
}

double chain_stable_dt() {
  const double l = 2 * kRc - kOverlap, S = 4 * kRc * kRc, G = kLambda * S / l;
  return 0.9 * kRho * kCp * 4.0 / 3.0 * M_PI * kRc * kRc * kRc / (2 * G);
}

Row run_chain(const std::string& scheme, double factor, double s_exp, double t_end) {
  State s;
  build_chain(s);
  ElectricalNetwork::Params ep;
  ep.model = "transmission_surface";
  ep.alpha_constant = 4.0;
  ep.resistivity = kRhoE;
  ep.conductivity = 1.0 / kRhoE;
  ep.high = "last";
  ep.low = "first";
  ep.voltage = kVolt;
  ElectricalNetwork el(ep);
  HeatConduction::Params hp;
  hp.model = "transmission_surface";
  hp.alpha_constant = 4.0;
  hp.conductivity = kLambda;
  hp.density = kRho;
  hp.specific_heat = kCp;
  hp.scheme = scheme;
  hp.joule_heating = true;
  hp.fixed_sets = "ends";
  hp.fixed_temperatures = {300.0};
  HeatConduction heat(hp);
  Clock one;
  one.kind = Clock::Kind::EveryStep;
  heat.set_clock(one);
  ContactModelT<HertzMindlin> law{HertzMindlin::Params{}};
  Simulation sim(s, law);
  sim.add_module(&el);
  sim.add_module(&heat);
  const double dt = factor * s_exp * (scheme == "explicit" ? 1.0 - 1e-12 : 1.0);
  const Step n = static_cast<Step>(std::llround(t_end / (factor * s_exp)));
  const double wall = timed_run(sim, dt, n);
  const Eigen::VectorXd ref = chain_reference(static_cast<double>(n) * dt);
  const auto& T = s.particles.fields.data("temperature");
  Row r{"chain", scheme, factor, dt, static_cast<double>(n) * dt, n};
  for (int i = 0; i < kChainN; ++i) r.error = std::max(r.error, std::abs(T[i] - ref[i]));
  r.ref_excursion = ref.maxCoeff() - 300.0;
  r.wall = wall;
  return r;
}

std::string g(double x, int digits = 4) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*g", digits, x);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    fs::path out = ".";
    bool quick = false;
    for (int a = 1; a < argc; ++a) {
      const std::string s = argv[a];
      if (s == "--out" && a + 1 < argc)
        out = argv[++a];
      else if (s == "--quick")
        quick = true;
      else
        throw std::runtime_error("unknown argument " + s);
    }
    std::vector<Row> rows;
    const std::vector<double> fe = {1.0, 0.5, 0.25, 0.1}, be = {1.0, 10.0, 100.0, 1000.0};
    auto add_orders = [&](std::size_t from) {
      for (std::size_t k = from + 1; k < rows.size(); ++k)
        if (rows[k].scheme == rows[k - 1].scheme && rows[k].problem == rows[k - 1].problem)
          rows[k].order = std::log(rows[k - 1].error / rows[k].error) / std::log(rows[k - 1].dt / rows[k].dt);
    };
    {
      const double s_exp = StiffScene::explicit_stable_dt();
      const double t_end = (quick ? 2000.0 : 20000.0) * s_exp;
      for (const char* scheme : {"explicit", "implicit"}) {
        const std::size_t from = rows.size();
        for (double f : std::string(scheme) == "explicit" ? fe : be) {
          if (quick && f == 1000.0) continue;
          rows.push_back(run_stiff(scheme, f, s_exp, t_end));
          std::cerr << rows.back().problem << " " << scheme << " x" << f << ": error " << rows.back().error << " K in " << rows.back().wall
                    << " s\n";
        }
        // implicit rows are listed from the largest step down for the order
        if (std::string(scheme) == "implicit") std::reverse(rows.begin() + static_cast<std::ptrdiff_t>(from), rows.end());
        add_orders(from);
      }
    }
    {
      const double s_exp = chain_stable_dt();
      const double t_end = (quick ? 200.0 : 2000.0) * s_exp;
      for (const char* scheme : {"explicit", "implicit"}) {
        const std::size_t from = rows.size();
        for (double f : std::string(scheme) == "explicit" ? fe : be) {
          if (quick && f == 1000.0) continue;
          rows.push_back(run_chain(scheme, f, s_exp, t_end));
          std::cerr << rows.back().problem << " " << scheme << " x" << f << ": error " << rows.back().error << " K in " << rows.back().wall
                    << " s\n";
        }
        if (std::string(scheme) == "implicit") std::reverse(rows.begin() + static_cast<std::ptrdiff_t>(from), rows.end());
        add_orders(from);
      }
    }
    fs::create_directories(out);
    std::ofstream csv(out / "results.csv");
    csv << "problem,scheme,dt_over_explicit_stable,dt_s,steps,t_end_s,error_K,reference_excursion_K,observed_order,wall_s\n";
    for (const Row& r : rows)
      csv << r.problem << "," << r.scheme << "," << g(r.factor, 6) << "," << g(r.dt, 8) << "," << r.steps << "," << g(r.t_end, 8) << ","
          << g(r.error, 6) << "," << g(r.ref_excursion, 6) << "," << (std::isnan(r.order) ? "" : g(r.order, 4)) << "," << g(r.wall, 4)
          << "\n";
    std::ofstream md(out / "results.md");
    md << "# heat_conduction: time-step convergence (bench_thermal_convergence" << (quick ? " --quick" : "") << ")\n\n"
       << "Error = max |T - T_ref| at t_end [K] (stiff: the three conducting 1 mm spheres; chain: all nodes), against the "
          "exact modal solution of the network; order = log(e_k / e_k+1) / log(dt_k / dt_k+1); wall = stage run time on "
          "one thread.\n\n"
       << "Explicit stable steps (0.9 x the Gershgorin bound min_i C_i / sum_j G_ij): stiff " << g(StiffScene::explicit_stable_dt(), 6)
       << " s (set by the 10 um sphere; the chain alone would allow "
       << g(0.9 * StiffScene::capacity(StiffScene::R) / (2 * StiffScene::g_ll()), 4) << " s), chain " << g(chain_stable_dt(), 6)
       << " s. Implicit rows run from the largest step down.\n\n"
       << "| problem | scheme | dt / explicit stable | dt [s] | steps | t_end [s] | error [K] | order | wall [s] |\n"
       << "|---|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const Row& r : rows)
      md << "| " << r.problem << " | " << r.scheme << " | " << g(r.factor) << " | " << g(r.dt) << " | " << r.steps << " | " << g(r.t_end)
         << " | " << g(r.error, 3) << " | " << (std::isnan(r.order) ? "" : g(r.order, 3)) << " | " << g(r.wall, 3) << " |\n";
    md << "\n";
    std::cout << "wrote " << (out / "results.csv").string() << " and " << (out / "results.md").string() << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "bench_thermal_convergence: " << e.what() << "\n";
    return 1;
  }
}
