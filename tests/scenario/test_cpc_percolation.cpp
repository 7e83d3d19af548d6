// The seed-002 pipeline through the scenario loader: cpc_fillers, touching_wall electrode sets
// on the generated faces, electrical_network (touching) and contact_percolation in the frozen
// evaluation of the generator stage, and a seeds sweep (the ensemble of configs/cpc_percolation.json).
//
// Invariants checked (exact or to solver precision):
//  - N = round(phi L^3 / (4/3 pi R^3)), the reported phi is N 4/3 pi R^3 / L^3, the largest
//    relative overlap is <= 1e-3;
//  - R_eq against an independent solve in this test: the network rebuilt from the frame's
//    positions and radii (every pair with a surface gap <= touch_tolerance = 0.002 is one unit
//    conductance, electrodes from the frame's set_x_lo / set_x_hi), the node equations of the
//    nodes connected to an electrode solved with Eigen's dense LU, I = the current leaving the
//    1 V electrode, R = 1 V / I: electrical_network's R_eq and contact_percolation's parallel
//    value within 1e-9 (both solvers' precision); Kirchhoff: the current entering the 0 V
//    electrode equals it (1e-9);
//  - resistivity of the cube of edge L between two opposite faces: rho = R A / L with A = L^2,
//    from the independent R (1e-9); finite R_eq if and only if spanning = 1; the paper's mean
//    over spanning clusters is >= the parallel value (equal with one spanning cluster);
//  - a seeds sweep reports per-seed spanning in {0, 1} and its mean is the spanning fraction.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/scratch.hpp"

namespace test_cpc_percolation {

using namespace sparkdem;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {
json run(const json& scene, const fs::path& out) {
  static const Registry reg = [] {
    Registry r;
    physics::register_all(r);
    return r;
  }();
  io::Scenario sc = io::load_scenario(scene, reg, fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  io::RunOptions opt;
  opt.outdir = out;
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}
json first_stage_only(json j) {
  j["stages"] = json::array({j["stages"][0]});
  return j;
}

/// Kirchhoff solve of the touching network of a frame, independent of the engine's graph and
/// Laplacian code: unit conductance between every pair with surface gap <= `touch` [m]; 1 V on
/// the set_x_lo particles, 0 V on set_x_hi. Returns the currents leaving the 1 V electrode and
/// entering the 0 V one [A] (0 when no path joins them).
std::pair<double, double> touching_network_currents(const fs::path& frame_file, double touch) {
  const auto f = io::H5File::open_read(frame_file);
  const auto x = f.read_doubles("/particles/position"), r = f.read_doubles("/particles/radius");
  const auto hi = f.read_doubles("/particles/set_x_lo"), lo = f.read_doubles("/particles/set_x_hi");
  const std::size_t n = r.size();
  std::vector<std::pair<std::size_t, std::size_t>> edges;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const double d = std::hypot(x[3 * i] - x[3 * j], x[3 * i + 1] - x[3 * j + 1], x[3 * i + 2] - x[3 * j + 2]);
      if (d - r[i] - r[j] <= touch) edges.emplace_back(i, j);
    }
  // Nodes joined to an electrode through the network (the others float: no equation).
  std::vector<std::vector<std::size_t>> adj(n);
  for (const auto& [i, j] : edges) {
    adj[i].push_back(j);
    adj[j].push_back(i);
  }
  std::vector<char> reached(n, 0);
  std::vector<std::size_t> stack;
  for (std::size_t i = 0; i < n; ++i)
    if (hi[i] > 0.5 || lo[i] > 0.5) {
      reached[i] = 1;
      stack.push_back(i);
    }
  while (!stack.empty()) {
    const std::size_t i = stack.back();
    stack.pop_back();
    for (std::size_t j : adj[i])
      if (!reached[j]) {
        reached[j] = 1;
        stack.push_back(j);
      }
  }
  std::vector<long> row(n, -1);  // unknown index of each free reached node
  long m = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (reached[i] && !(hi[i] > 0.5) && !(lo[i] > 0.5)) row[i] = m++;
  auto fixed = [&](std::size_t i) { return hi[i] > 0.5 ? 1.0 : 0.0; };
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(m, m);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(m);
  for (const auto& [i, j] : edges)
    for (const auto& [p, q] : {std::pair{i, j}, std::pair{j, i}}) {
      if (row[p] < 0) continue;
      A(row[p], row[p]) += 1.0;
      if (row[q] >= 0)
        A(row[p], row[q]) -= 1.0;
      else
        b(row[p]) += fixed(q);
    }
  const Eigen::VectorXd u = A.partialPivLu().solve(b);
  auto volt = [&](std::size_t i) { return row[i] >= 0 ? u(row[i]) : fixed(i); };
  double out_hi = 0.0, in_lo = 0.0;
  for (const auto& [i, j] : edges)
    for (const auto& [p, q] : {std::pair{i, j}, std::pair{j, i}}) {
      if (hi[p] > 0.5 && !(hi[q] > 0.5)) out_hi += volt(p) - volt(q);
      if (lo[p] > 0.5 && !(lo[q] > 0.5)) in_lo += volt(q) - volt(p);
    }
  return {out_hi, in_lo};
}
}  // namespace

TEST_CASE("cpc_fillers + contact_percolation through the scenario", "[cpc][scenario]") {
  test::ScratchDir tmp("sparkdem_cpc");
  const json scene = first_stage_only(test::load_data("cpc_small.json"));
  const double L = 14.0, phi = 0.3;
  const double n = std::round(phi * L * L * L / (4.0 / 3.0 * std::numbers::pi));
  for (const double lambda : {0.0, 6.0}) {
    json sc = scene;
    sc["stages"][0]["generator"]["aggregation_lambda"] = lambda;
    const fs::path out = tmp.path / ("lambda" + std::to_string(static_cast<int>(lambda)));
    const json s = run(sc, out);
    const json& st = s["stages"][0];
    const json& pk = st["packing"];
    CHECK(pk["particles"].get<double>() == n);
    CHECK(pk["volume_fraction"].get<double>() == Approx(n * 4.0 / 3.0 * std::numbers::pi / (L * L * L)).epsilon(1e-14));
    CHECK(pk["max_relative_overlap"].get<double>() <= 1e-3);
    if (lambda > 0.0) CHECK(pk["aggregation_moved"].get<double>() > 0.0);
    const json& f = st["final"];
    const double spanning = f["contact_percolation_spanning"].get<double>();
    CHECK((spanning == 0.0 || spanning == 1.0));
    CHECK(f["contact_percolation_coordination"].get<double>() > 0.5);
    const auto [I_hi, I_lo] = touching_network_currents(out / "frames/frame_000000.h5", 0.002);
    INFO("independent solve: I = " << I_hi << " A out of the 1 V electrode, " << I_lo << " A into the 0 V one");
    CHECK(std::abs(I_lo - I_hi) <= 1e-12 + 1e-9 * std::abs(I_hi));  // Kirchhoff: what leaves one electrode enters the other
    CHECK((I_hi > 1e-6) == (spanning == 1.0));                      // a path of <= N unit conductances carries >= 1/N A; none: round-off
    if (spanning == 1.0) {
      const double R = 1.0 / I_hi;  // [Ohm] 1 V across unit conductances
      CHECK(std::abs(f["electrical_resistance"].get<double>() / R - 1.0) < 1e-9);
      CHECK(std::abs(f["contact_percolation_resistance"].get<double>() / R - 1.0) < 1e-9);
      CHECK(std::abs(f["contact_percolation_resistance_parallel"].get<double>() / R - 1.0) < 1e-9);
      CHECK(f["contact_percolation_resistance_cluster_mean"].get<double>() >= R * (1.0 - 1e-9));
      CHECK(std::abs(f["contact_percolation_resistivity"].get<double>() / (R * (L * L) / L) - 1.0) < 1e-9);  // rho = R A / L
    } else {
      CHECK(f["electrical_resistance"].is_null());  // +inf is written as null
      CHECK(f["contact_percolation_conductivity"].get<double>() == 0.0);
    }
  }
}

TEST_CASE("cpc_fillers: a seeds sweep gives the spanning fraction", "[cpc][scenario]") {
  test::ScratchDir tmp("sparkdem_cpc_sweep");
  json sc = first_stage_only(test::load_data("cpc_small.json"));
  sc["stages"][0]["generator"]["volume_fraction"] = 0.2;
  sc["stages"][0]["sweep"] = {{"seeds", {1, 2, 3, 4}}, {"collect", {"contact_percolation_spanning", "contact_percolation_conductivity"}}};
  const json s = run(sc, tmp.path / "out");
  std::ifstream in(tmp.path / "out" / "sweep_fillers.csv");
  REQUIRE(in.good());
  std::string header, line;
  std::getline(in, header);
  int rows = 0;
  while (std::getline(in, line))
    if (!line.empty()) ++rows;
  CHECK(rows >= 4);
  const json& stats = s["stages"][0]["sweep"]["statistics"]["contact_percolation_spanning"];
  CHECK(stats["count"].get<int>() == 4);
  const double mean = stats["mean"].get<double>();
  CHECK((mean == 0.0 || mean == 0.25 || mean == 0.5 || mean == 0.75 || mean == 1.0));
}

/// The fillers stage of cpc_small with ptc_strain on the RKPM continuum, every length scaled by
/// `scale` (radius, box, node spacing) and the penalty alpha = alpha_R_over_E E / R (E = 1 Pa).
json rkpm_scene(double scale, double alpha_R_over_E, double break_gap_rel) {
  json sc = first_stage_only(test::load_data("cpc_small.json"));
  auto& st = sc["stages"][0];
  st["generator"]["radius"] = scale * 1.0;
  st["generator"]["box_length"] = scale * 14.0;
  auto& m = st["modules"]["ptc_strain"];
  m["matrix_model"] = "rkpm";
  m["node_spacing"] = scale * 2.0;
  m["cut_cell_depth"] = 0;
  m["bond_penalty"] = alpha_R_over_E / scale;  // [Pa/m] with matrix_modulus 1 Pa
  m["break_gap_rel"] = break_gap_rel;
  m["eps0_values"] = json::array({0.0, 0.002, 0.01});
  st["modules"].erase("electrical_network");
  return sc;
}

TEST_CASE("ptc_strain: the switching strain does not depend on the scene's size (relative thresholds)", "[cpc][ptc][scenario]") {
  // Every length (R, box, node spacing) x 10 and x 1e-6 with alpha R / E fixed: the same fillers
  // (the contact algorithm works in units of R), the same contacts, openings ~ R: the switching
  // strain moves only by round-off. Tolerance 1e-6 relative (issue 60).
  test::ScratchDir tmp("sparkdem_ptc_scale");
  const json base = run(rkpm_scene(1.0, 10.0, 1e-3), tmp.path / "s1")["stages"][0]["final"];
  const double eps = base["ptc_strain_switching_strain"].get<double>();
  INFO("switching strain at R = 1 m: " << eps << ", contacts " << base["ptc_strain_contacts"]);
  REQUIRE(eps > 0.0);
  REQUIRE(std::isfinite(eps));
  for (const double scale : {10.0, 1e-6}) {
    const json f = run(rkpm_scene(scale, 10.0, 1e-3), tmp.path / ("s" + std::to_string(scale)))["stages"][0]["final"];
    INFO("scale " << scale << ": switching strain " << f["ptc_strain_switching_strain"]);
    CHECK(f["ptc_strain_contacts"].get<double>() == base["ptc_strain_contacts"].get<double>());
    CHECK(f["ptc_strain_closing_candidates"].get<double>() == base["ptc_strain_closing_candidates"].get<double>());
    CHECK(std::abs(f["ptc_strain_switching_strain"].get<double>() / eps - 1.0) <= 1e-6);
    CHECK(std::abs(f["ptc_strain_opening_mean"].get<double>() / base["ptc_strain_opening_mean"].get<double>() - 1.0) <= 1e-6);
  }
}

TEST_CASE("ptc_strain: the switching strain scales with the break threshold", "[cpc][ptc][scenario]") {
  // A contact opens at (b D - h) / delta: with h << b D every break strain, hence the switch,
  // is ~ proportional to b (issue 60 measured 9.7x for 10x). Checked within 10 % at the two
  // penalties the issue names (alpha R / E = 1.43 and 10).
  test::ScratchDir tmp("sparkdem_ptc_break");
  for (const double a : {1.43, 10.0}) {
    const std::string tag = std::to_string(static_cast<int>(100 * a));
    const double e1 = run(rkpm_scene(1.0, a, 1e-3), tmp.path / ("b1_" + tag))["stages"][0]["final"]["ptc_strain_switching_strain"].get<double>();
    const double e10 = run(rkpm_scene(1.0, a, 1e-2), tmp.path / ("b10_" + tag))["stages"][0]["final"]["ptc_strain_switching_strain"].get<double>();
    INFO("alpha R / E = " << a << ": switching strain " << e1 << " (break 0.1 % of D), " << e10 << " (1 %)");
    REQUIRE(e1 > 0.0);
    CHECK(e10 / e1 == Approx(10.0).epsilon(0.10));
  }
}

}  // namespace test_cpc_percolation
