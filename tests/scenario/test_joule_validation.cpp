/// Invariants of seed 001's two Joule-heating scenes (cohesive-joule-torsion.md 7.3, 7.4), run in
/// CI on the shipped scenarios configs/joule_rod.json and configs/joule_notch.json with small
/// packings. The figures against the analytic rise and the finite-volume R_eq are the validation
/// ledger's (tools/validate.py: cases seed001/joule_rod and seed001/notch; their fast tier runs in
/// CI as the ctests validate_fast/seed001/joule_rod and validate_fast/seed001/notch with bands
/// derived from the measured seed-to-seed scatter, benchmarks/validation/fast_bands.json).
///
/// Uniform rod, N = 400 (relax packing of the config, only `particles` changed): capacity "domain"
/// makes the capacities sum to rho c V_g, the field is solved once and the rod is adiabatic, so the
/// mean rise is dV^2 t / (R_DEM rho c V_g) to round-off (bound 1e-9) and the energy balance closes
/// (1e-12); the scenario's check reports (rise - reference) / reference of the reference written
/// into it before the run (149.532 K, Eq. 1 at N = 400).
///
/// Notched bar, N = 620 before the cut: the config's relax packing with only `particles` changed,
/// then its notch and joule stages as shipped: the energy balance closes (1e-12) and at most
/// 2 % of the particles float (cut off by the slots).
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_joule_validation {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json load_config(const std::string& name) { return json::parse(std::ifstream(fs::path(SPARKDEM_SOURCE_DIR) / "configs" / name)); }

json run(const json& scene, const fs::path& out) {
  io::Scenario sc = io::load_scenario(scene, test::registry(), fs::path(SPARKDEM_SOURCE_DIR) / "configs");
  io::RunOptions opt;
  opt.outdir = out;
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}

const json& stage_named(const json& summary, const std::string& name) {
  for (const auto& st : summary["stages"])
    if (st["name"] == name) return st;
  FAIL("no stage " << name << " in the summary");
  return summary;
}

}  // namespace

TEST_CASE("joule rod, N = 400: mean rise = dV^2 t / (R_DEM rho c V) exactly, energy balance closed", "[joule][heat][scenario]") {
  json scene = load_config("joule_rod.json");
  json& gen = scene["stages"][0]["generator"];
  REQUIRE(scene["stages"][0]["type"] == "relax");
  const int n = 400;
  gen["particles"] = n;
  const double r_d = gen["radius"].get<double>(), l_d = gen["length"].get<double>();
  const double V_g = M_PI * r_d * r_d * l_d;
  const double r_eq1 = std::cbrt(0.63 * V_g / (4.0 / 3.0 * M_PI * n));
  const json& st = scene["stages"][1];
  const json& el = st["modules"]["electrical_network"];
  const json& he = st["modules"]["heat_conduction"];
  const double rho_e = el["resistivity"].get<double>(), dV = el["voltage"].get<double>();
  const double rho = he["density"].get<double>(), c = he["specific_heat"].get<double>(), t = st["stop"]["time"].get<double>();
  REQUIRE(he["capacity"] == "domain");
  REQUIRE(std::abs(he["domain_volume"].get<double>() / V_g - 1.0) < 1e-15);
  const double R_th = rho_e * (l_d - 2.0 * r_eq1) / (M_PI * r_d * r_d);
  const double dT_ref = dV * dV * t / (R_th * rho * c * V_g);
  REQUIRE(std::abs(dT_ref - 149.532) < 1e-3);  // the value stated above
  scene["checks"][0]["reference"] = 149.532;

  test::ScratchDir tmp("sparkdem_joule_rod_small");
  const json s = run(scene, tmp.path / "out");
  REQUIRE(s["status"] == "completed");
  const json& f = stage_named(s, "joule")["final"];
  const double R = f["electrical_resistance"].get<double>();
  const double dT = f["heat_temperature_mean"].get<double>() - he["initial_temperature"].get<double>();
  const double dT_bk = dV * dV * t / (R * rho * c * V_g);
  INFO("R_DEM = " << R << " Ohm, R_th = " << R_th << " Ohm (" << 100.0 * (R / R_th - 1.0) << " %); rise " << dT << " K, analytic " << dT_ref
                  << " K (" << 100.0 * (dT / dT_ref - 1.0) << " %), with R_DEM " << dT_bk << " K; relax "
                  << stage_named(s, "cook")["wall_time_s"] << " s, joule " << stage_named(s, "joule")["wall_time_s"] << " s");
  CHECK(std::abs(dT / dT_bk - 1.0) <= 1e-9);
  CHECK(f["heat_balance_error"].get<double>() <= 1e-12);
  // The scenario's check evaluates the rise against the reference written into it before the run.
  CHECK(std::abs(s["checks"]["uniform_rod_temperature_rise"]["error_rel"].get<double>() - (dT / 149.532 - 1.0)) <= 1e-12);
}

TEST_CASE("notched bar, N = 620: energy balance closed, network connected", "[joule][notch][scenario]") {
  json scene = load_config("joule_notch.json");
  REQUIRE(scene["stages"][0]["type"] == "relax");
  scene["stages"][0]["generator"]["particles"] = 620;
  scene["checks"] = json::array();  // the shipped references belong to the N = 5000 packing

  test::ScratchDir tmp("sparkdem_joule_notch_small");
  const json s = run(scene, tmp.path / "out");
  REQUIRE(s["status"] == "completed");
  State st;
  io::read_checkpoint(tmp.path / "out" / "final_state.h5", st);
  const json& f = stage_named(s, "joule")["final"];
  INFO("R_DEM = " << f["electrical_resistance"].get<double>() << " Ohm; particles " << st.particles.size() << "; relax "
                  << stage_named(s, "cook")["wall_time_s"] << " s, joule " << stage_named(s, "joule")["wall_time_s"] << " s");
  CHECK(f["heat_balance_error"].get<double>() <= 1e-12);
  CHECK(f["electrical_floating_nodes"].get<double>() <= 0.02 * static_cast<double>(st.particles.size()));
}

}  // namespace test_joule_validation
