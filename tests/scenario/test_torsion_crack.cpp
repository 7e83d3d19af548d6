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
}  // namespace

TEST_CASE("small cohesive-beam pin twisted to separation: twist, onset, log and resistance are consistent",
          "[torsion][beam][electrical][scenario]") {
  Registry reg;
  physics::register_all(reg);
  const json scene = test::load_data("torsion_small.json");
  io::Scenario sc = io::load_scenario(scene, reg, fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  test::ScratchDir tmp("sparkdem_torsion_small");
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  const json summary = io::run_scenario(sc, opt);
  REQUIRE(summary["status"] == "completed");
  const double w = 1000.0, pin_r = 4e-4, pin_l = 1.6e-3;

  const auto ts = read_csv(opt.outdir / "timeseries.csv");
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
  const auto log = read_csv(opt.outdir / "broken_bonds.csv");
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
