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

#include <algorithm>
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

namespace test_torsion_crack {

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
  out = tmp.path / "out";
  return test::run_scene(scene, base, out);
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

namespace {
/// configs/torsion_crack.json with only the element count reduced (5000 -> 1000) and the two
/// lengths that follow the element size scaled with it (an absolute bond gap tolerance, the
/// end-set thickness), as benchmarks/torsion_crack/run_torsion.py does. Beams: the committed
/// calibration (configs/materials/cast_iron_beams_torsion.json, made in torsion on 5000-element
/// pins of packing seeds 101-105).
json pin_1000() {
  json scene = json::parse(std::ifstream(fs::path(SPARKDEM_SOURCE_DIR) / "configs/torsion_crack.json"));
  const double scale = std::cbrt(5000.0 / 1000.0);
  scene["stages"][0]["generator"]["particles"] = 1000;
  json& cb = scene["stages"][1]["create_bonds"];
  if (cb.contains("gap_tolerance")) cb["gap_tolerance"] = cb["gap_tolerance"].get<double>() * scale;
  for (auto& s : scene["particle_sets"]) s["thickness"] = s["thickness"].get<double>() * scale;
  return scene;
}

/// Time-series columns of the twist stage (stage 1) before the first broken bond: twist, the two
/// end torques, kinetic and elastic energy, R / R0.
struct IntactRows {
  std::vector<double> twist, clamped, twisted, kinetic, elastic, ratio;
};
IntactRows intact_rows(const fs::path& csv) {
  const auto ts = read_csv(csv);
  const auto& head = ts.at(0);
  auto idx = [&](const std::string& n) { return static_cast<std::size_t>(std::find(head.begin(), head.end(), n) - head.begin()); };
  const std::size_t c_stage = idx("stage"), c_br = idx("bonds_broken"), c_tw = idx("torsion_twist"), c_tc = idx("torsion_torque"),
                    c_tt = idx("torsion_torque_twisted_end"), c_ke = idx("kinetic_energy"), c_ue = idx("bonds_elastic_energy"),
                    c_r = idx("torsion_resistance_ratio");
  REQUIRE(c_r < head.size());
  IntactRows out;
  for (std::size_t r = 1; r < ts.size(); ++r) {
    if (ts[r][c_stage] != "1" || ts[r][c_tw].empty() || ts[r][c_tw] == "nan") continue;
    if (std::stod(ts[r][c_br]) > 0.0) break;
    out.twist.push_back(std::stod(ts[r][c_tw]));
    out.clamped.push_back(std::stod(ts[r][c_tc]));
    out.twisted.push_back(std::stod(ts[r][c_tt]));
    out.kinetic.push_back(std::stod(ts[r][c_ke]));
    out.elastic.push_back(std::stod(ts[r][c_ue]));
    out.ratio.push_back(ts[r][c_r] == "nan" ? NAN : std::stod(ts[r][c_r]));
  }
  return out;
}

/// Least-squares slope k of y = k x through the origin [N m / rad].
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  double xx = 0.0, xy = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    xx += x[k] * x[k];
    xy += x[k] * y[k];
  }
  return xy / xx;
}

/// Checks on the intact pin (every row before the first break):
///  - action = reaction: the torque the clamped set takes and the torque applied at the twisted
///    set differ by the rate of change of the interior's angular momentum only, which oscillates
///    about zero in a quasi-static twist: their least-squares slopes against the twist agree
///    within 1 % (measured 1.6e-4 at N = 1000, seed 1; single rows differ by up to 2 %);
///  - quasi-static past 0.005 rad: kinetic energy below 5 % of the bonds' elastic energy;
///  - R / R0 within 1e-3 of 1 (the elastic twist changes the transmission surfaces only at
///    second order).
void check_intact(const IntactRows& rows) {
  REQUIRE(rows.twist.size() >= 20);
  const double k_clamped = slope(rows.twist, rows.clamped), k_twisted = slope(rows.twist, rows.twisted);
  INFO("torque slopes: clamped " << k_clamped << " N m/rad, twisted end " << k_twisted << " N m/rad over " << rows.twist.size() << " rows");
  CHECK(k_clamped > 0.0);
  CHECK(std::abs(k_clamped / k_twisted - 1.0) < 0.01);
  double worst_ke = 0.0, worst_r = 0.0;
  for (std::size_t k = 0; k < rows.twist.size(); ++k) {
    if (rows.twist[k] > 0.005) worst_ke = std::max(worst_ke, rows.kinetic[k] / rows.elastic[k]);
    if (!std::isnan(rows.ratio[k])) worst_r = std::max(worst_r, std::abs(rows.ratio[k] - 1.0));
  }
  CHECK(worst_ke < 0.05);
  CHECK(worst_r < 1e-3);
}
}  // namespace

TEST_CASE("pin torsion (configs/torsion_crack.json at N = 1000) in the elastic range: torque against G J theta / L, action = reaction",
          "[torsion][beam][electrical][scenario][regression]") {
  // The fast variant of the [slow] case below: twisted to 0.03 rad (8e-5 s at 375 rad/s), before
  // the predicted first break (0.0416 rad). Stiffness: least-squares torque / (G J theta / L)
  // within 0.10 of 1.21, a regression guard around the N = 1000 figure of the fast tier
  // (benchmarks/validation/fast_bands.json seed001/torsion_stiffness@N1000: +20.7 % +- 3 x 3.1 % over
  // packing seeds 1-5, beams calibrated in torsion at N = 5000; the validation figures are the
  // ledger's seed001/torsion_*: the elastic response drifts with the element size).
  json scene = pin_1000();
  scene["stages"][1]["stop"] = {{"time", 0.03 / 375.0}};
  test::ScratchDir tmp("sparkdem_torsion_1000_elastic");
  fs::path out;
  const json summary = run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "configs", tmp, out);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  INFO("stiffness ratio " << f["torsion_stiffness_ratio"] << ", twist " << f["torsion_twist"] << " rad");
  CHECK(std::abs(f["torsion_twist"].get<double>() - 0.03) < 1e-3);
  CHECK(f["bonds_broken"].get<double>() == 0.0);
  CHECK(std::abs(f["torsion_stiffness_ratio"].get<double>() - 1.21) < 0.10);
  check_intact(intact_rows(out / "timeseries.csv"));
}

TEST_CASE("pin torsion (configs/torsion_crack.json at N = 1000): elastic torque, onset near tau_y L / (G r), resistance rise",
          "[torsion][beam][electrical][scenario][regression][slow]") {
  // The shipped scenario at N = 1000 (pin_1000) to separation, 0.09 rad. The bands here are
  // regression guards around the fast tier's N = 1000 figures (benchmarks/validation/fast_bands.json,
  // packing seeds 1-5: stiffness +20.7 % +- 3 x 3.1 %, first break +4.1 % +- 3 x 6.3 %), not the
  // issue's 3 % / 5 % (the ledger's full tier): stiffness within 0.10 of 1.21 G J / L, first break
  // within 0.19 of 1.04 x 0.0416 rad, the pin still conducting like an intact one
  // at 0.03 rad (R/R0 < 1.01; since issue 20 the crack runs before 0.05 rad) and more than 1.5 R0
  // at 0.07 rad (seed 001: more than doubled), and
  // the intact-pin checks of check_intact (action = reaction, quasi-static, R unchanged).
  // [slow]: 40 s on one thread; the elastic range runs in the fast suite (test above).
  test::ScratchDir tmp("sparkdem_torsion_1000");
  fs::path out;
  const json summary = run_scene(pin_1000(), fs::path(SPARKDEM_SOURCE_DIR) / "configs", tmp, out);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  const double predicted = 400e6 * 5e-3 / (48.062e9 * 1e-3);
  INFO("stiffness ratio " << f["torsion_stiffness_ratio"] << ", first break " << f["torsion_break_onset_twist"] << " rad, R/R0 at 0.05 "
                          << f["torsion_resistance_ratio_at_0.05"] << ", at 0.07 " << f["torsion_resistance_ratio_at_0.07"]);
  CHECK(std::abs(f["torsion_stiffness_ratio"].get<double>() - 1.21) < 0.10);
  CHECK(std::abs(f["torsion_break_onset_twist"].get<double>() / predicted - 1.04) < 0.19);
  CHECK(f["torsion_resistance_ratio_at_0.03"].get<double>() < 1.01);
  const json& r07 = f["torsion_resistance_ratio_at_0.07"];
  CHECK((r07.is_null() || r07.get<double>() > 1.5));  // null: +inf, separated
  check_intact(intact_rows(out / "timeseries.csv"));
}

TEST_CASE("pin torsion at gap <= 0 (configs/torsion_contact.json at N = 600), unbreakable beams: no crack onset from R",
          "[torsion][beam][electrical][scenario]") {
  // Issue 58 item 5: the detector must stay silent on an elastic-only twist. The shipped scene
  // (beams between elements in contact, the R-trend detector's committed constants) at N = 600
  // with the beam strength 1e30, twisted to 0.07 rad (1.7 x the predicted onset): no bond breaks,
  // so any trend onset would be a false alarm. R still moves: the elements' transmission
  // surfaces follow their current eccentricity (Eq. 3's switch at e = 0.4), steps the fit's
  // residual deviation has to cover.
  json scene = json::parse(std::ifstream(fs::path(SPARKDEM_SOURCE_DIR) / "configs/torsion_contact.json"));
  const double scale = std::cbrt(5000.0 / 600.0);
  scene["stages"][0]["generator"]["particles"] = 600;
  for (auto& s : scene["particle_sets"]) s["thickness"] = s["thickness"].get<double>() * scale;
  scene["bonds"]["params"]["strength"] = 1e30;
  scene["stages"][1]["stop"] = {{"time", 0.07 / 375.0}};
  scene["checks"] = json::array();
  test::ScratchDir tmp("sparkdem_torsion_contact_elastic");
  fs::path out;
  const json summary = run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "configs", tmp, out);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  INFO("twist " << f["torsion_twist"] << " rad, trend samples " << f["torsion_resistance_trend_samples"] << ", last departure "
                << f["torsion_resistance_trend_departure"] << ", R/R0 " << f["torsion_resistance_ratio"]);
  CHECK(std::abs(f["torsion_twist"].get<double>() - 0.07) < 1e-3);
  CHECK(f["bonds_broken"].get<double>() == 0.0);
  CHECK(f["torsion_resistance_trend_samples"].get<double>() >= 6.0);
  CHECK(f["torsion_resistance_trend_onset_twist"].is_null());  // NaN (never detected) is written as null
  CHECK(std::abs(f["torsion_resistance_trend_departure"].get<double>()) < 1.0);
}

}  // namespace test_torsion_crack
