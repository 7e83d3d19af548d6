/// configs/thermal_stiff.json (the stiff heat network of tests/support/thermal_network.hpp as a
/// scenario): its two checks pass with the implicit scheme at 1000 x the explicit stable step
/// (hottest temperature against the exact modal solution within the backward-Euler bound 1.4 %,
/// heat conserved to 1e-9); with "scheme": "explicit" the stage runs 1000 adaptive substeps per
/// step and the hottest temperature is within 1e-4 of the exact one (forward Euler at h = the
/// stable step: error ~ 1e-3 of the implicit one); on a fixed every_step clock the explicit
/// stage is refused (SetupError naming the module and both steps).
#include <catch2/catch.hpp>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "engine/core/error.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_thermal_stiff {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json run(const json& scene, const std::string& tag) {
  test::ScratchDir tmp("sparkdem_thermal_stiff_" + tag);
  io::Scenario sc = io::load_scenario(scene, test::registry(), tmp.path);
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}
}  // namespace

TEST_CASE("configs/thermal_stiff.json: implicit at 1000 x the explicit step within its bound, explicit on 1000 substeps",
          "[scenario][thermal][stiff]") {
  const json scene = io::read_json_file(fs::path(SPARKDEM_SOURCE_DIR) / "configs/thermal_stiff.json");
  const double exact = 129.0977;  // hottest temperature - 300 K (the scene's check reference)
  SECTION("implicit (as shipped)") {
    const json s = run(scene, "implicit");
    REQUIRE(s["status"] == "completed");
    for (const char* c : {"hottest_temperature", "mean_temperature_conserved"}) {
      INFO(c << ": " << s["checks"][c].dump());
      CHECK(s["checks"][c]["within_tolerance"].get<bool>());
    }
    CHECK(s["stages"][4]["module_calls"]["heat_conduction"].get<long>() == 20);
  }
  SECTION("explicit") {
    json e = scene;
    e["stages"][4]["modules"]["heat_conduction"]["scheme"] = "explicit";
    const json s = run(e, "explicit");
    REQUIRE(s["status"] == "completed");
    CHECK(s["stages"][4]["module_calls"]["heat_conduction"].get<long>() == 20000);
    const double v = s["checks"]["hottest_temperature"]["value"].get<double>();
    CHECK(std::abs(v - exact) <= 1e-4 * exact);
    CHECK(s["checks"]["mean_temperature_conserved"]["within_tolerance"].get<bool>());
  }
  SECTION("explicit on a fixed clock: refused") {
    json e = scene;
    e["stages"][4]["modules"]["heat_conduction"]["scheme"] = "explicit";
    e["stages"][4]["modules"]["heat_conduction"]["clock"] = {{"kind", "every_step"}};
    CHECK_THROWS_AS(run(e, "refused"), SetupError);
  }
}

}  // namespace test_thermal_stiff
