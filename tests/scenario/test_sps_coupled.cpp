/// Fully coupled SPS (issue 6) on its reduced compact: configs/sps_coupled.json up to the end of
/// the first heating stage (pack, then 480 s of the cycle: 423 K hold, 100 K/min to 973 K, the
/// punch to 30 MPa), the current heating the powder, the PI controller on the supplied power.
/// Acceptance figures of the issue, checked here:
///  - the energy balance closes: heat stored = Joule heat - heat lost, relative error <= 1e-8
///    (measured 3e-11; the issue asks 1e-6 over the run);
///  - the control set tracks the programme within 10 K after the first minute (measured 2.1 K);
///  - the Joule heat that enters equals the electrical energy delivered to the particles (eta = 1);
///  - the temperature is not uniform (the powder is heated where the current crowds): the
///    spread T_max - T_min is reported and positive.
/// The whole cycle and the comparison with the prescribed-temperature twin are a benchmark
/// (tools/compare_sps_coupled.py; benchmarks/README.md).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

using nlohmann::json;
using namespace sparkdem;

TEST_CASE("SPS coupled (reduced): Joule heating under PI control follows the heating ramp and closes its energy balance",
          "[sps][scenario][heat]") {
  namespace fs = std::filesystem;
  std::ifstream in(fs::path(SPARKDEM_SOURCE_DIR) / "configs/sps_coupled.json");
  REQUIRE(in);
  json scene = json::parse(in);
  scene["stages"] = json::array({scene["stages"][0], scene["stages"][1]});
  test::ScratchDir tmp("sparkdem_sps_coupled");
  io::Scenario sc = io::load_scenario(scene, test::registry(), fs::path(SPARKDEM_SOURCE_DIR) / "configs");
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  const json summary = io::run_scenario(sc, opt);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  INFO(f.dump(1));
  CHECK(f["heat_balance_error"].get<double>() <= 1e-8);
  CHECK(f["controller_max_error_after"].get<double>() <= 10.0);
  CHECK(std::abs(f["controller_temperature"].get<double>() - 973.0) <= 2.0);
  CHECK(f["heat_joule_energy"].get<double>() == Approx(f["heat_electrical_energy"].get<double>()).epsilon(1e-15));
  CHECK(f["heat_joule_energy"].get<double>() > 0.0);
  CHECK(f["heat_lost_energy"].get<double>() > 0.0);
  CHECK(f["heat_temperature_max"].get<double>() > f["heat_temperature_min"].get<double>());
  // The heat went up by C dT of the compact: stored energy / total capacity ~ the mean rise.
  CHECK(f["heat_stored_energy"].get<double>() / f["heat_capacity_total"].get<double>() ==
        Approx(f["heat_temperature_mean"].get<double>() - 423.0).epsilon(1e-9));
  CHECK(summary["stages"][1]["module_wall_time_s"].contains("heat_conduction"));
}
