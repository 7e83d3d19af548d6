/// Self-heating PTC current limiter (issue 8 part 4) on the small element of
/// tests/scenario/data/ptc_self_heating_small.json (196 fillers, R = 5 um; ptc_self_heating ->
/// electrical_network (touching, displacement_field) -> implicit heat_conduction with losses),
/// run at a voltage below and one above the trip level, 2 s (about 7.5 thermal time constants)
/// with dt = 1 ms. What is checked, each against an invariant or the run's own measurements:
///  * energy: the Joule energy heat_conduction integrated equals the sum over the steps of the
///    electrical power times dt (the zero-order hold; 1e-9 relative), and the heat balance
///    stored + lost = Joule closes (heat_balance_error <= 1e-9);
///  * the trip level: the low run is at steady state (mean T moved < 0.05 K over the last 100
///    steps) and its effective loss conductance H = P / (T_mean - T_amb) predicts the trip
///    voltage V_trip = sqrt(R_cold H (T_switch - T_amb)) (uniform-heating estimate); the low
///    voltage is below it, the high one above it;
///  * below the trip level the element stays cold-conducting: final current = the cold current
///    (1e-3 relative) and every filler stays below the switching temperature;
///  * above it, it trips and limits the current: over the last third of the run the median
///    current is below 1/100 of the cold current and the mean (with the relaxation spikes of the
///    reconnecting contacts) below 1/10; the mean temperature regulates near T_switch (within
///    10 % of T_switch - T_amb).
/// Run time: about 2 s (two runs of 2000 steps).
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/scratch.hpp"

namespace test_ptc_self_heating {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

namespace {
/// Rows of stage 1 of OUT/timeseries.csv, one per step (the final row repeats the last step).
std::vector<std::map<std::string, double>> stage_rows(const fs::path& file) {
  std::ifstream in(file);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  {
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) head.push_back(c);
  }
  std::vector<std::map<std::string, double>> rows;
  double last_step = -1.0;
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::map<std::string, double> r;
    std::size_t k = 0;
    for (std::string c; std::getline(ss, c, ',') && k < head.size(); ++k) r[head[k]] = c.empty() ? NAN : std::strtod(c.c_str(), nullptr);
    if (r["stage"] != 1.0 || r["step"] == last_step) continue;
    last_step = r["step"];
    rows.push_back(r);
  }
  return rows;
}

std::vector<std::map<std::string, double>> run_at(double volts, const test::ScratchDir& tmp, const std::string& name) {
  json scene = test::load_data("ptc_self_heating_small.json");
  scene["stages"][1]["modules"]["electrical_network"]["voltage"] = volts;
  io::Scenario sc = io::load_scenario(scene, test::registry(), fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  io::RunOptions opt;
  opt.outdir = tmp.path / name;
  opt.quiet = true;
  opt.threads = 1;
  const json summary = io::run_scenario(sc, opt);
  REQUIRE(summary["status"] == "completed");
  return stage_rows(opt.outdir / "timeseries.csv");
}

void check_energy(const std::vector<std::map<std::string, double>>& r, double dt) {
  double sum = 0.0;
  for (std::size_t k = 1; k < r.size(); ++k) sum += r[k].at("electrical_power") * dt;  // row 0: stage start
  const double E = r.back().at("heat_electrical_energy");
  INFO("sum P dt " << sum << " J, heat_electrical_energy " << E << " J");
  CHECK(std::abs(sum - E) <= 1e-9 * E);
  const double stored = r.back().at("heat_stored_energy"), lost = r.back().at("heat_lost_energy"), joule = r.back().at("heat_joule_energy");
  CHECK(std::abs(stored + lost - joule) <= 1e-9 * joule);
  CHECK(r.back().at("heat_balance_error") <= 1e-9);
}
}  // namespace

TEST_CASE("ptc self-heating element: energy balance, cold conduction below the trip level, current limiting above",
          "[ptc][cpc][electrical][thermal][scenario]") {
  test::ScratchDir tmp("sparkdem_ptc_self_heating");
  const double dt = 1e-3, T_amb = 293.15, v_low = 0.3, v_high = 3.0;
  const auto lo = run_at(v_low, tmp, "low");
  const auto hi = run_at(v_high, tmp, "high");
  REQUIRE(lo.size() == 2001);
  REQUIRE(hi.size() == 2001);
  check_energy(lo, dt);
  check_energy(hi, dt);

  const double T_sw = lo.back().at("ptc_self_heating_switching_temperature");
  REQUIRE(std::isfinite(T_sw));
  REQUIRE(T_sw > T_amb);
  // Cold current: the first solve, at the ambient temperature.
  const double I0_lo = lo[1].at("electrical_current"), I0_hi = hi[1].at("electrical_current");
  const double R_cold = v_low / I0_lo;
  CHECK(std::abs(v_high / I0_hi - R_cold) <= 1e-9 * R_cold);  // the same cold network

  // Trip level from the low run's steady state.
  const double Tm_end = lo.back().at("heat_temperature_mean");
  CHECK(std::abs(Tm_end - lo[lo.size() - 101].at("heat_temperature_mean")) < 0.05);
  const double H = lo.back().at("electrical_power") / (Tm_end - T_amb);  // W/K
  const double v_trip = std::sqrt(R_cold * H * (T_sw - T_amb));
  INFO("T_switch " << T_sw << " K, R_cold " << R_cold << " Ohm, H " << H << " W/K, V_trip " << v_trip << " V");
  CHECK(v_low < 0.8 * v_trip);
  CHECK(v_high > 2.0 * v_trip);

  // Below: cold-conducting at steady state, every filler below the switching temperature.
  CHECK(std::abs(lo.back().at("electrical_current") / I0_lo - 1.0) < 1e-3);
  CHECK(lo.back().at("heat_temperature_max") < T_sw);

  // Above: tripped and self-regulated near T_switch over the last third.
  std::vector<double> I;
  double Tsum = 0.0;
  for (std::size_t k = 2 * hi.size() / 3; k < hi.size(); ++k) {
    I.push_back(hi[k].at("electrical_current"));
    Tsum += hi[k].at("heat_temperature_mean");
  }
  const double Tbar = Tsum / static_cast<double>(I.size());
  double mean = 0.0;
  for (double x : I) mean += x;
  mean /= static_cast<double>(I.size());
  std::sort(I.begin(), I.end());
  const double median = I[I.size() / 2];
  INFO("cold current " << I0_hi << " A, late median " << median << " A, late mean " << mean << " A, late mean T " << Tbar << " K");
  CHECK(median < I0_hi / 100.0);
  CHECK(mean < I0_hi / 10.0);
  CHECK(std::abs(Tbar - T_sw) < 0.1 * (T_sw - T_amb));
}

}  // namespace test_ptc_self_heating
