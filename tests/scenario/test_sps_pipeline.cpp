/// The SPS pipeline end to end on its reduced variant (configs/sps_nial_small.json: ~300 NiAl
/// particles packed from the seed-000 size distribution, cold pressed while heated to 973 K, hot
/// pressed with the sintering law along the 1300 C / 30 MPa cycle in physical time, snapshots when
/// the porosity by mass crosses 0.30 and the four measured porosities, the grain-boundary layer
/// calibrated on porosity 0.164, each snapshot's conductivity with and without the layer).
/// Checks physics that must hold whatever the calibration:
///  - the calibration reaches its target on its snapshot (1e-3) and validates every snapshot at
///    the calibrated value;
///  - the hot press densifies: porosity_mass falls from the deposit to the end of the cycle;
///  - each snapshot is taken within 0.01 of its target porosity (check every 100 steps);
///  - per snapshot: Kirchhoff (electrode currents equal to 1e-10 relative, power = V I to 1e-10),
///    and the grain-boundary layer lowers the conductivity;
///    (kappa_eff < kappa_0 is NOT asserted: without the layer, the sintered-neck network of a
///    compact with necks a/r_min ~ 0.8 reaches the bulk value, 9.77e6 against 9.8e6 S/m at
///    porosity 0.216 in this run, and exceeded it in earlier runs — the hemisphere law ignores how
///    overlaps shorten the particles; see docs/physics.md);
///  - the denser snapshot conducts better (with and without the layer).
#include <catch2/catch.hpp>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_sps_pipeline {

using nlohmann::json;
using namespace sparkdem;

namespace {
namespace fs = std::filesystem;

/// configs/sps_nial_small.json without its last stage (cooled_conductivity: 100,000 steps, a
/// third of the run, and nothing of it is checked here); the stages checked keep their indices.
json small_pipeline() {
  std::ifstream in(fs::path(SPARKDEM_SOURCE_DIR) / "configs/sps_nial_small.json");
  REQUIRE(in);
  json scene = json::parse(in);
  REQUIRE(scene["stages"].back()["name"] == "cooled_conductivity");
  scene["stages"].erase(scene["stages"].size() - 1);
  return scene;
}

/// Runs the scene and checks the list at the top of this file.
void check_pipeline(const json& scene) {
  test::ScratchDir tmp("sparkdem_sps");
  const json summary = test::run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "configs", tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  const json& press = summary["stages"][2];
  REQUIRE(press["name"] == "hot_press");
  const json& taken = press["snapshots"]["taken"];
  REQUIRE(taken.size() >= 2);
  // Densification: the compact ends denser than at its first snapshot (crossed from above).
  CHECK(press["final"]["porosity_mass"].get<double>() < taken[0]["value"].get<double>());
  for (const auto& t : taken) CHECK(std::abs(t["value"].get<double>() - t["target"].get<double>()) < 0.01);
  const json& cal = summary["stages"][3]["sweep"]["calibration"];
  CHECK(std::abs(cal["achieved"].get<double>() / cal["target"].get<double>() - 1.0) <= 1e-3);
  json gb = json::array();
  for (const auto& r : summary["stages"][3]["sweep"]["rows"])
    if (r["phase"] == "validate") {
      CHECK(r["value"].get<double>() == cal["value"].get<double>());
      gb.push_back(r);
    }
  const json& nogb = summary["stages"][4]["sweep"]["rows"];
  REQUIRE(gb.size() == taken.size());
  REQUIRE(nogb.size() == taken.size());
  for (std::size_t k = 0; k < gb.size(); ++k) {
    const json& a = gb[k]["values"];
    const json& b = nogb[k]["values"];
    INFO("snapshot " << k << ": kappa_eff with layer " << a["electrical_conductivity_eff"] << ", without "
                     << b["electrical_conductivity_eff"]);
    for (const json* v : {&a, &b}) {
      CHECK((*v)["electrical_current_mismatch"].get<double>() < 1e-10);
      CHECK((*v)["electrical_power_mismatch"].get<double>() < 1e-10);
      CHECK((*v)["electrical_conductivity_eff"].get<double>() > 0.0);
    }
    CHECK(a["electrical_conductivity_eff"].get<double>() < b["electrical_conductivity_eff"].get<double>());
    if (k > 0) {
      CHECK(a["electrical_conductivity_eff"].get<double>() > gb[k - 1]["values"]["electrical_conductivity_eff"].get<double>());
      CHECK(b["electrical_conductivity_eff"].get<double>() > nogb[k - 1]["values"]["electrical_conductivity_eff"].get<double>());
    }
  }
}
}  // namespace

TEST_CASE("SPS pipeline (reduced) to porosity 0.216: packing, hot press, two porosity snapshots, calibrated conductivity sweep",
          "[sps][scenario]") {
  // The fast variant of the [slow] case below (65 % of its hot-press steps): the hot press stops
  // below porosity 0.21, after the snapshots at 0.30 and 0.216, and the grain-boundary layer is
  // calibrated on the 0.216 sample (seed 000 Table 1: 4.33e6 S/m) instead of 0.164.
  json scene = small_pipeline();
  scene["stages"][2]["snapshots"]["at"] = json::array({0.3, 0.216});
  scene["stages"][2]["until"] = {{"porosity_mass", {{"below", 0.21}}}};
  auto& cal = scene["stages"][3]["sweep"]["calibrate"];
  REQUIRE(cal["snapshot"] == 2);
  cal["snapshot"] = 1;
  cal["target"] = 4.33e6;
  check_pipeline(scene);
}

TEST_CASE("SPS pipeline (reduced): packing, hot press, porosity snapshots, calibrated conductivity sweep", "[sps][scenario][slow]") {
  // All five snapshots (to porosity 0.05); [slow]: 30 s alone under load, 70 s and more beside
  // other tests; the fast variant above checks the same on the first three.
  check_pipeline(small_pipeline());
}

}  // namespace test_sps_pipeline
