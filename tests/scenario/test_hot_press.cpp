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
#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_hot_press {

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

/// Porosity of a frame's spheres in a die of radius `R` between z = 0 and z = `H` (no sphere may
/// reach the die): without and with the sphere-sphere lenses subtracted.
struct Porosities {
  double mass = 0.0, lenses = 0.0;
};
Porosities frame_porosities(const fs::path& frame, double R, double H) {
  constexpr double pi = 3.14159265358979323846;
  const auto f = io::H5File::open_read(frame);
  const auto x = f.read_doubles("/particles/position"), r = f.read_doubles("/particles/radius");
  auto cap = [&](std::size_t i, double d) { return d > 0.0 ? pi * d * d * (3.0 * r[i] - d) / 3.0 : 0.0; };
  double solid = 0.0, lenses = 0.0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    REQUIRE(std::hypot(x[3 * i], x[3 * i + 1]) + r[i] < R);
    solid += 4.0 / 3.0 * pi * r[i] * r[i] * r[i] - cap(i, r[i] - x[3 * i + 2]) - cap(i, x[3 * i + 2] + r[i] - H);
    for (std::size_t j = i + 1; j < r.size(); ++j) {
      const double l = std::hypot(x[3 * i] - x[3 * j], x[3 * i + 1] - x[3 * j + 1], x[3 * i + 2] - x[3 * j + 2]);
      const double s = r[i] + r[j];
      if (l < s) lenses += pi * (s - l) * (s - l) * (l * l + 2.0 * l * s - 3.0 * (r[i] - r[j]) * (r[i] - r[j])) / (12.0 * l);
    }
  }
  const double V = pi * R * R * H;
  return {1.0 - solid / V, 1.0 - (solid - lenses) / V};
}
}  // namespace

TEST_CASE("hot press scene: temperature, physical time and compact columns", "[thermal][compact][scenario]") {
  // 4000 steps of 2e-5 s at time_scale 1000 = 80 physical seconds: the temperature is the
  // table's last value (900 K, exact), the compact height is the top plane (z = 12.5 mm) minus
  // its offset (1e-15 m), and the porosity lies between 0.3 and 0.9 (36 spheres of r = 1.03 mm
  // fill 0.11 of the die to 12.5 mm and 0.18 to 8 mm). The porosities against the geometry of
  // the final frame (closed forms, 1e-12): V = pi R_die^2 H; porosity_mass = 1 - (sum 4/3 pi r^3
  // - punch caps) / V, a cap of depth d being pi d^2 (3 r - d) / 3; porosity (and 1 -
  // relative_density) subtracts the sphere-sphere lenses too, pi (r_a + r_b - l)^2 (l^2 + 2 l
  // (r_a + r_b) - 3 (r_a - r_b)^2) / (12 l) at centre distance l.
  // The pressure table (physical seconds: 2 kPa from 30 s = 0.03 s mechanical on) is reached:
  // the punch force is 2000 Pa x pi (6 mm)^2 within 1 % at the end.
  json scene = test::load_data("hot_press_small.json");
  test::ScratchDir tmp("sparkdem_hot_press");
  const json summary = test::run_scene(scene, tmp.path, tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  const json& f = summary["stages"][1]["final"];
  CHECK(summary["stages"][1]["physical_time_s"].get<double>() == Approx(80.0).epsilon(1e-12));
  CHECK(f["temperature"].get<double>() == 900.0);
  CHECK(std::abs(f["compact_height"].get<double>() - (0.0125 - f["wall_top_offset"].get<double>())) <= 1e-15);
  const Porosities ref = frame_porosities(tmp.path / "out" / "frames/frame_000001.h5", 0.006, 0.0125 - f["wall_top_offset"].get<double>());
  CHECK(std::abs(f["porosity_mass"].get<double>() - ref.mass) <= 1e-12);
  CHECK(std::abs(f["porosity"].get<double>() - ref.lenses) <= 1e-12);
  CHECK(std::abs(f["relative_density"].get<double>() - (1.0 - ref.lenses)) <= 1e-12);
  CHECK(ref.lenses > ref.mass);  // the spheres overlap: the lenses count once
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
    CHECK(e.count("/stages/1/compact/die"));     // a plane given as the die
    CHECK(e.count("/stages/1/compact/bottom"));  // no such wall (did you mean "bottom"?)
    CHECK(e.at("/stages/1/compact/bottom").find("did you mean \"bottom\"") != std::string::npos);
    CHECK(e.count("/stages/1/compact/top"));  // a cylinder given as a punch
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
  REQUIRE(j["stage"]["keys"].contains("compact"));
  REQUIRE(j["monitors"].contains("compact"));
  bool unit_ok = false;
  for (const auto& p : j["modules"]["temperature_history"]["params"])
    if (p["name"] == "expansion_coefficient") unit_ok = p["unit"] == "1/K";
  CHECK(unit_ok);
}

}  // namespace test_hot_press
