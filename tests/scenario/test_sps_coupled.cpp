/// Fully coupled SPS (issue 6) on its reduced compact: configs/sps_coupled.json up to the end of
/// the first heating stage (pack, then 480 s of the cycle: 423 K hold, 100 K/min to 973 K, the
/// punch to 30 MPa), the current heating the powder, the PI controller on the supplied power.
/// Acceptance figures of the issue, checked here:
///  - the energy balance closes: heat stored = Joule heat - heat lost, relative error <= 1e-8
///    (measured 3e-11; the issue asks 1e-6 over the run);
///  - the control set tracks the programme within 10 K after the first minute (measured 2.1 K);
///  - energy conservation across the two modules (eta = 1): the energy the supply delivers,
///    integral of V I dt over the electrical_network's own columns (trapezoid rule on rows 10
///    steps apart, from step 200 on: the controller's start-up switches the power on and off within
///    the first 15 steps, which no sampling resolves), equals the heat the heat module took in over
///    the same rows, the change of heat_stored_energy + heat_lost_energy, within 1e-3 (the
///    trapezoid rule's sampling error of the step-to-step power, measured 6e-5; with rows every
///    step the two agree to 4e-15);
///  - the stored heat, recomputed from the final frame with the material's constants,
///    sum rho c (4/3) pi r_ref^3 (T - 423 K), equals heat_stored_energy (1e-12), and each radius
///    is r_ref (1 + alpha (T - T_ref)) (1e-12);
///  - the temperature is not uniform (the powder is heated where the current crowds): the
///    spread T_max - T_min is reported and positive.
/// The whole cycle and the comparison with the prescribed-temperature twin are a benchmark
/// (tools/compare_sps_coupled.py; benchmarks/README.md).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>

#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_sps_coupled {

using nlohmann::json;
using namespace sparkdem;

namespace {
namespace fs = std::filesystem;

/// Energy the supply delivered between the first stage-`stage` row at or after step `from` and
/// the last row: trapezoid rule on P = electrical_voltage x electrical_current over physical
/// time. Also returns the change of heat_stored_energy + heat_lost_energy over the same rows.
struct Window {
  double supplied = 0.0, taken_in = 0.0;
  std::size_t rows = 0;
};
Window supply_window(const fs::path& results, double stage, double from) {
  const auto f = io::H5File::open_read(results);
  auto col = [&](const std::string& n) { return f.read_doubles("/timeseries/" + n); };
  const auto st = col("stage"), step = col("step"), t = col("physical_time"), V = col("electrical_voltage"), I = col("electrical_current"),
             stored = col("heat_stored_energy"), lost = col("heat_lost_energy");
  Window w;
  std::size_t first = st.size(), last = 0;
  for (std::size_t k = 0; k < st.size(); ++k) {
    if (st[k] != stage || step[k] < from) continue;
    if (first == st.size())
      first = k;
    else
      w.supplied += 0.5 * (V[k] * I[k] + V[last] * I[last]) * (t[k] - t[last]);
    last = k;
    ++w.rows;
  }
  if (w.rows > 1) w.taken_in = (stored[last] + lost[last]) - (stored[first] + lost[first]);
  return w;
}
}  // namespace

TEST_CASE("SPS coupled (reduced): Joule heating under PI control follows the heating ramp and closes its energy balance",
          "[sps][scenario][heat]") {
  std::ifstream in(fs::path(SPARKDEM_SOURCE_DIR) / "configs/sps_coupled.json");
  REQUIRE(in);
  json scene = json::parse(in);
  scene["stages"] = json::array({scene["stages"][0], scene["stages"][1]});
  scene["stages"][1]["output"]["timeseries_every"] = 10;  // rows for the V I integral (200 in the config)
  test::ScratchDir tmp("sparkdem_sps_coupled");
  const json summary = test::run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "configs", tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  INFO(f.dump(1));
  CHECK(f["heat_balance_error"].get<double>() <= 1e-8);
  CHECK(f["controller_max_error_after"].get<double>() <= 10.0);
  CHECK(std::abs(f["controller_temperature"].get<double>() - 973.0) <= 2.0);
  CHECK(f["heat_joule_energy"].get<double>() > 0.0);
  CHECK(f["heat_lost_energy"].get<double>() > 0.0);
  CHECK(f["heat_temperature_max"].get<double>() > f["heat_temperature_min"].get<double>());
  // Energy delivered by the supply (electrical columns) = heat taken in (heat columns), eta = 1.
  const Window w = supply_window(tmp.path / "out" / "results.h5", 1.0, 200.0);
  INFO("supplied " << w.supplied << " J, stored + lost " << w.taken_in << " J over " << w.rows << " rows");
  REQUIRE(w.rows > 600);
  CHECK(w.taken_in > 0.9 * f["heat_joule_energy"].get<double>());  // the window holds nearly all the heating
  CHECK(std::abs(w.supplied / w.taken_in - 1.0) <= 1e-3);
  // Stored heat from the final frame: C_i = rho c (4/3) pi r_ref^3 (configs/sps_coupled.json:
  // rho = 5910 kg/m^3, c = 600 J/(kg K), capacity "sphere"), every particle started at 423 K.
  const auto frame = io::H5File::open_read(tmp.path / "out" / "frames/frame_000001.h5");
  REQUIRE(static_cast<double>(frame.attribute_int64("/", "step")) == f["step"].get<double>());  // the stage's last state
  const auto T = frame.read_doubles("/particles/temperature"), r = frame.read_doubles("/particles/radius"),
             r_ref = frame.read_doubles("/particles/radius_ref");
  REQUIRE(T.size() == r_ref.size());
  const double rho = 5910.0, c = 600.0, alpha = 1.51e-5, T_ref = 293.15;
  double stored = 0.0, worst_radius = 0.0;
  for (std::size_t i = 0; i < T.size(); ++i) {
    stored += rho * c * 4.0 / 3.0 * std::numbers::pi * std::pow(r_ref[i], 3) * (T[i] - 423.0);
    worst_radius = std::max(worst_radius, std::abs(r[i] / (r_ref[i] * (1.0 + alpha * (T[i] - T_ref))) - 1.0));
  }
  CHECK(std::abs(stored / f["heat_stored_energy"].get<double>() - 1.0) <= 1e-12);
  CHECK(worst_radius <= 1e-12);
  CHECK(summary["stages"][1]["module_wall_time_s"].contains("heat_conduction"));
}

}  // namespace test_sps_coupled
