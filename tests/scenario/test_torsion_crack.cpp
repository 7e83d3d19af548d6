/// Pin torsion with cohesive beams and the electrical network on the intact bonds (issue 7), on
/// the small pin of tests/scenario/data/torsion_small.json (400 elements, a weak strength so that
/// it cracks through within 4e-5 s). What is checked, each against an invariant of the run:
///  * the twist column is the prescribed rotation w t at every row (1e-9 relative);
///  * before the first break the resistance does not move (R/R0 within 1e-3 of 1: the elastic
///    twist changes the transmission-surface geometry only at second order);
///  * the onset twist of torsion_test is w x the time of the first row of broken_bonds.csv (the
///    log), the log holds exactly the broken bonds of the table (count per mode = bonds_broken);
///  * once the pin has separated the resistance is infinite and the separation twist is reported;
///  * every broken bond's logged midpoint lies inside the pin.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/scratch.hpp"

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

namespace {
std::vector<std::vector<std::string>> read_csv(const fs::path& f) {
  std::vector<std::vector<std::string>> rows;
  std::ifstream in(f);
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> r;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) r.push_back(c);
    rows.push_back(r);
  }
  return rows;
}

/// Load `scene` (relative paths against `base`), run it into a scratch directory with one thread
/// and return the summary; `out` receives the output directory.
json run_scene(const json& scene, const fs::path& base, const test::ScratchDir& tmp, fs::path& out) {
  Registry reg;
  physics::register_all(reg);
  io::Scenario sc = io::load_scenario(scene, reg, base);
  io::RunOptions opt;
  opt.outdir = out = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}
}  // namespace

TEST_CASE("small cohesive-beam pin twisted to separation: twist, onset, log and resistance are consistent",
          "[torsion][beam][electrical][scenario]") {
  test::ScratchDir tmp("sparkdem_torsion_small");
  fs::path out;
  const json summary = run_scene(test::load_data("torsion_small.json"), fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data", tmp, out);
  REQUIRE(summary["status"] == "completed");
  const double w = 1000.0, pin_r = 4e-4, pin_l = 1.6e-3;

  const auto ts = read_csv(out / "timeseries.csv");
  const auto& head = ts.at(0);
  auto idx = [&](const std::string& n) {
    for (std::size_t k = 0; k < head.size(); ++k)
      if (head[k] == n) return k;
    FAIL("no column " << n);
    return std::size_t{0};
  };
  const std::size_t c_stage = idx("stage"), c_time = idx("time"), c_twist = idx("torsion_twist"), c_ratio = idx("torsion_resistance_ratio"),
                    c_broken = idx("bonds_broken");
  double t0 = NAN;
  int before_break = 0;
  for (std::size_t r = 1; r < ts.size(); ++r) {
    if (std::stod(ts[r][c_stage]) != 1.0) continue;
    const double t = std::stod(ts[r][c_time]);
    if (std::isnan(t0)) t0 = t;
    const double twist = std::stod(ts[r][c_twist]);
    CHECK(std::abs(twist - w * (t - t0)) <= 1e-9 * std::max(1e-12, w * (t - t0)) + 1e-15);
    if (std::stod(ts[r][c_broken]) == 0.0 && t > t0) {
      ++before_break;
      CHECK(std::abs(std::stod(ts[r][c_ratio]) - 1.0) < 1e-3);
    }
  }
  CHECK(before_break >= 2);

  const json& st = summary["stages"][1];
  const double broken = st["final"]["bonds_broken"].get<double>();
  REQUIRE(broken > 0);
  const auto log = read_csv(out / "broken_bonds.csv");
  REQUIRE(log.size() == static_cast<std::size_t>(broken) + 1);
  double by_mode = 0.0;
  for (const auto& [m, n] : st["bonds"]["broken_by_mode"].items()) by_mode += n.get<double>();
  CHECK(by_mode == broken);
  const double t_first = std::stod(log[1][1]);
  CHECK(std::abs(st["final"]["torsion_break_onset_twist"].get<double>() - w * (t_first - t0)) < 1e-9);
  for (std::size_t r = 1; r < log.size(); ++r) {
    const double x = std::stod(log[r][4]), y = std::stod(log[r][5]), z = std::stod(log[r][6]);
    CHECK(std::hypot(x, y) < pin_r);
    CHECK(z > 0.0);
    CHECK(z < pin_l);
  }
  // Separated: no intact path between the end sets.
  CHECK(st["final"]["torsion_resistance_ratio"].is_null());  // +inf is written as null
  CHECK(st["final"]["torsion_separation_twist"].get<double>() > st["final"]["torsion_break_onset_twist"].get<double>());
}

TEST_CASE("pin torsion (configs/torsion_crack.json at N = 1000): elastic torque, onset near tau_y L / (G r), resistance rise",
          "[torsion][beam][electrical][scenario][validation]") {
  // The shipped scenario with only the element count reduced (5000 -> 1000) and the two lengths
  // that follow the element size scaled with it (bond gap tolerance, end-set thickness), as
  // benchmarks/torsion_crack/run_torsion.py does. Beams: the committed calibration
  // (configs/materials/cast_iron_beams.json, made on a tension sample at the N = 5000 element
  // size). Measured before the validation ledger (benchmarks/torsion_crack/results.md as of commit
  // 81fc62f; the validation figures are now the ledger's seed001/torsion_*): stiffness ratio
  // 1.134 / 0.993 / 0.913 and first-break twist +1.2 / -4.0 / -13.0 % at N = 1000 / 2500 / 5000 -
  // the elastic response drifts with the element size because the packing protocol does (see README). The
  // bands here are regression guards around the N = 1000 figures, not the 3 % / 5 %:
  // stiffness within 20 % of G J / L, first break within 15 % of 0.0416 rad, the pin still
  // conducting like an intact one at 0.05 rad (R/R0 < 1.1) and more than 1.5 R0 at 0.07 rad
  // (seed 001: more than doubled), quasi-static before the first break (kinetic < 5 % of elastic).
  const fs::path configs = fs::path(SPARKDEM_SOURCE_DIR) / "configs";
  json scene = json::parse(std::ifstream(configs / "torsion_crack.json"));
  const double scale = std::cbrt(5000.0 / 1000.0);
  scene["stages"][0]["generator"]["particles"] = 1000;
  scene["stages"][1]["create_bonds"]["gap_tolerance"] = scene["stages"][1]["create_bonds"]["gap_tolerance"].get<double>() * scale;
  for (auto& s : scene["particle_sets"]) s["thickness"] = s["thickness"].get<double>() * scale;
  test::ScratchDir tmp("sparkdem_torsion_1000");
  fs::path out;
  const json summary = run_scene(scene, configs, tmp, out);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  const double predicted = 400e6 * 5e-3 / (48.062e9 * 1e-3);
  INFO("stiffness ratio " << f["torsion_stiffness_ratio"] << ", first break " << f["torsion_break_onset_twist"] << " rad, R/R0 at 0.05 "
                          << f["torsion_resistance_ratio_at_0.05"] << ", at 0.07 " << f["torsion_resistance_ratio_at_0.07"]);
  CHECK(std::abs(f["torsion_stiffness_ratio"].get<double>() - 1.0) < 0.20);
  CHECK(std::abs(f["torsion_break_onset_twist"].get<double>() / predicted - 1.0) < 0.15);
  CHECK(f["torsion_resistance_ratio_at_0.05"].get<double>() < 1.1);
  const json& r07 = f["torsion_resistance_ratio_at_0.07"];
  CHECK((r07.is_null() || r07.get<double>() > 1.5));  // null: +inf, separated
  // Quasi-static before the first break: kinetic against elastic energy on every row past 0.005 rad.
  const auto ts = read_csv(out / "timeseries.csv");
  std::size_t c_ke = 0, c_ue = 0, c_br = 0, c_tw = 0;
  for (std::size_t k = 0; k < ts[0].size(); ++k) {
    if (ts[0][k] == "kinetic_energy") c_ke = k;
    if (ts[0][k] == "bonds_elastic_energy") c_ue = k;
    if (ts[0][k] == "bonds_broken") c_br = k;
    if (ts[0][k] == "torsion_twist") c_tw = k;
  }
  double worst = 0.0;
  for (std::size_t r = 1; r < ts.size(); ++r) {
    if (ts[r][c_br].empty() || ts[r][c_tw].empty() || ts[r][c_tw] == "nan") continue;
    if (std::stod(ts[r][c_br]) > 0.0) break;
    if (std::stod(ts[r][c_tw]) > 0.005) worst = std::max(worst, std::stod(ts[r][c_ke]) / std::stod(ts[r][c_ue]));
  }
  CHECK(worst < 0.05);
  // Every figure of the scenario's checks is in the summary with its error and the stage's run time.
  REQUIRE(summary.contains("checks"));
  CHECK(summary["checks"].size() == 4);
}
