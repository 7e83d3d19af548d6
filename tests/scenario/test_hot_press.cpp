/// The hot-press pieces through a scenario run in process (tests/scenario/data/hot_press_small.json:
/// 36 spheres in a die, top punch pressure-controlled with a table in physical seconds,
/// temperature_history with thermal expansion, the "compact" porosity monitor), and their
/// configuration errors with JSON paths.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "engine/core/error.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

std::map<std::string, std::string> errors_of(const json& scene) {
  std::map<std::string, std::string> out;
  try {
    io::load_scenario(scene, test::registry(), fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  } catch (const ConfigError& e) {
    for (const auto& d : e.diagnostics()) out[d.path] = d.message;
  }
  return out;
}
}  // namespace

TEST_CASE("hot press scene: temperature, physical time and compact columns", "[thermal][compact][scenario]") {
  // 4000 steps of 2e-5 s at time_scale 1000 = 80 physical seconds: the temperature is the
  // table's last value (900 K, exact), the compact height is the top plane (z = 12.5 mm) minus
  // its offset (1e-15 m), relative_density = 1 - porosity (1e-15), and the porosity lies between
  // 0.3 and 0.9 (36 spheres of r = 1.03 mm fill 0.11 of the die to 12.5 mm and 0.18 to 8 mm).
  // The pressure table (physical seconds: 2 kPa from 30 s = 0.03 s mechanical on) is reached:
  // the punch force is 2000 Pa x pi (6 mm)^2 within 1 % at the end.
  json scene = test::load_data("hot_press_small.json");
  test::ScratchDir tmp("sparkdem_hot_press");
  io::Scenario sc = io::load_scenario(scene, test::registry(), tmp.path);
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  const json summary = io::run_scenario(sc, opt);
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  CHECK(summary["stages"][1]["physical_time_s"].get<double>() == Approx(80.0).epsilon(1e-12));
  CHECK(f["temperature"].get<double>() == 900.0);
  CHECK(std::abs(f["compact_height"].get<double>() - (0.0125 - f["wall_top_offset"].get<double>())) <= 1e-15);
  CHECK(std::abs(f["relative_density"].get<double>() + f["porosity"].get<double>() - 1.0) <= 1e-15);
  CHECK(f["porosity"].get<double>() > 0.3);
  CHECK(f["porosity"].get<double>() < 0.9);
  CHECK(std::isfinite(f["porosity_interior"].get<double>()));
  CHECK(f["wall_top_normal_force"].get<double>() == Approx(2000.0 * 3.14159265358979 * 36e-6).epsilon(0.01));
}

TEST_CASE("hot press configuration errors carry their JSON paths", "[thermal][compact][scenario][config]") {
  json scene = test::load_data("hot_press_small.json");
  SECTION("compact: unknown wall, wrong shapes, same punch twice") {
    scene["stages"][1]["compact"] = {{"die", "bottom"}, {"bottom", "botom"}, {"top", "die"}};
    const auto e = errors_of(scene);
    INFO(e.size() << " errors");
    CHECK(e.count("/stages/1/compact/die"));      // a plane given as the die
    CHECK(e.count("/stages/1/compact/bottom"));   // no such wall (did you mean "bottom"?)
    CHECK(e.at("/stages/1/compact/bottom").find("did you mean \"bottom\"") != std::string::npos);
    CHECK(e.count("/stages/1/compact/top"));      // a cylinder given as a punch
  }
  SECTION("compact: negative margin, unknown key") {
    scene["stages"][1]["compact"]["interior_margin"] = -1.0;
    scene["stages"][1]["compact"]["margin"] = 1.0;
    const auto e = errors_of(scene);
    CHECK(e.count("/stages/1/compact/interior_margin"));
    CHECK(e.count("/stages/1/compact/margin"));
  }
  SECTION("temperature_history: every table problem at once") {
    scene["stages"][1]["modules"]["temperature_history"] = {{"time", {0, 10, 5}}, {"temperature", {300, 0}}};
    const auto e = errors_of(scene);
    CHECK(e.size() == 3);
    CHECK(e.count("/stages/1/modules/temperature_history/temperature"));
    CHECK(e.count("/stages/1/modules/temperature_history/time/2"));
    CHECK(e.count("/stages/1/modules/temperature_history/temperature/1"));
  }
  SECTION("until and snapshots may use the compact columns") {
    scene["stages"][1]["until"] = {{"relative_density", {{"above", 0.99}}}};
    scene["stages"][1]["snapshots"] = {{"column", "porosity"}, {"at", {0.5}}};
    CHECK(errors_of(scene).empty());
    scene["stages"][1]["snapshots"]["column"] = "porosty";
    CHECK(errors_of(scene).count("/stages/1/snapshots/column"));
  }
}

TEST_CASE("sparkdem schema lists temperature_history and the compact stage key", "[thermal][compact][scenario]") {
  const json j = io::schema_json(test::registry());
  REQUIRE(j["modules"].contains("temperature_history"));
  REQUIRE(j["stage"].contains("compact"));
  bool unit_ok = false;
  for (const auto& p : j["modules"]["temperature_history"]["params"])
    if (p["name"] == "expansion_coefficient") unit_ok = p["unit"] == "1/K";
  CHECK(unit_ok);
}
