// The seed-002 pipeline through the scenario loader: cpc_fillers, touching_wall electrode sets
// on the generated faces, electrical_network (touching) and contact_percolation in the frozen
// evaluation of the generator stage, and a seeds sweep (the ensemble of configs/cpc_percolation.json).
//
// Invariants checked (exact or to solver precision):
//  - N = round(phi L^3 / (4/3 pi R^3)), the reported phi is N 4/3 pi R^3 / L^3, the largest
//    relative overlap is <= 1e-3;
//  - the electrical_network's R_eq (one system, shared electrodes) equals the parallel
//    combination of the per-cluster resistances of contact_percolation's own solve (1e-9);
//    resistivity = R_eq L; finite R_eq if and only if spanning = 1; the paper's mean over
//    spanning clusters is >= the parallel value (equal with one spanning cluster);
//  - a seeds sweep reports per-seed spanning in {0, 1} and its mean is the spanning fraction.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/scratch.hpp"

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
}  // namespace

TEST_CASE("cpc_fillers + contact_percolation through the scenario", "[cpc][scenario]") {
  test::ScratchDir tmp("sparkdem_cpc");
  const json scene = first_stage_only(test::load_data("cpc_small.json"));
  const double L = 14.0, phi = 0.3;
  const double n = std::round(phi * L * L * L / (4.0 / 3.0 * std::numbers::pi));
  for (const double lambda : {0.0, 6.0}) {
    json sc = scene;
    sc["stages"][0]["generator"]["aggregation_lambda"] = lambda;
    const json s = run(sc, tmp.path / ("lambda" + std::to_string(static_cast<int>(lambda))));
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
    if (spanning == 1.0) {
      const double R = f["electrical_resistance"].get<double>();
      CHECK(f["contact_percolation_resistance"].get<double>() == R);
      CHECK(std::abs(f["contact_percolation_resistance_parallel"].get<double>() / R - 1.0) < 1e-9);
      CHECK(f["contact_percolation_resistance_cluster_mean"].get<double>() >= R * (1.0 - 1e-9));
      CHECK(std::abs(f["contact_percolation_resistivity"].get<double>() / (R * L) - 1.0) < 1e-14);
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
  sc["stages"][0]["sweep"] = {{"seeds", {1, 2, 3, 4}},
                              {"collect", {"contact_percolation_spanning", "contact_percolation_conductivity"}}};
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
