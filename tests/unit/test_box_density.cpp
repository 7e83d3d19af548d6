/// The "box_density" stage key (physics/packing/box_density.hpp), the stage key added by following
/// the recipe of docs/ARCHITECTURE.md: the monitor against closed forms (a sphere inside, one cut
/// in half by a face, one outside), its loader errors with JSON pointers and did-you-mean, its
/// columns known at load time, and a run whose box holds the whole lattice.
#include <catch2/catch.hpp>

#include <cmath>
#include <map>
#include <numbers>

#include "engine/core/error.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/packing/box_density.hpp"
#include "support/scratch.hpp"

namespace test_box_density {

using namespace sparkdem;
using nlohmann::json;

namespace {

std::map<std::string, std::string> load_errors(const json& scene) {
  std::map<std::string, std::string> out;
  try {
    io::load_scenario(scene, test::registry(), SPARKDEM_SOURCE_DIR);
  } catch (const ConfigError& e) {
    for (const auto& d : e.diagnostics()) out[d.path] = d.message;
  }
  return out;
}

}  // namespace

TEST_CASE("box_density: solid fraction and centre count against closed forms", "[box_density][unit]") {
  const double r = 0.1, kPi = std::numbers::pi;
  State s;
  // Inside; centred on the face x = 1 (half inside, centre on the boundary counts); outside.
  for (const Vec3& x : {Vec3(0.5, 0.5, 0.5), Vec3(1.0, 0.5, 0.5), Vec3(3.0, 0.5, 0.5)}) {
    const Index i = s.particles.add(x, r, 1.0);
    (void)i;
  }
  physics::BoxDensityMonitor m({Vec3::Zero(), Vec3::Ones()});
  REQUIRE(m.columns(s) == std::vector<std::string>{"box_solid_fraction", "box_particles"});
  const auto v = m.values(s);
  const double sphere = 4.0 / 3.0 * kPi * r * r * r;
  CHECK(v[0] == Approx(1.5 * sphere / 1.0).epsilon(1e-12));  // box volume 1 m^3
  CHECK(v[1] == 2.0);
}

TEST_CASE("box_density: a stage key with JSON-pointer errors, did-you-mean and known columns", "[box_density][config_errors][scenario]") {
  json scene = test::load_data("restart_pour.json");
  scene["stages"][1]["stop"] = {{"steps", 20}};
  SECTION("hi not above lo, an unknown key") {
    scene["stages"][1]["box_density"] = {{"lo", {0, 0, 0}}, {"hi", {1, 1, 0}}};
    auto e = load_errors(scene);
    CHECK(e.count("/stages/1/box_density/hi"));
    scene["stages"][1]["box_density"] = {{"lo", {0, 0, 0}}, {"high", {1, 1, 1}}};
    e = load_errors(scene);
    REQUIRE(e.count("/stages/1/box_density/high"));
    CHECK(e.at("/stages/1/box_density/high").find("did you mean \"hi\"") != std::string::npos);
  }
  SECTION("a misspelt stage key suggests it") {
    scene["stages"][1]["box_densty"] = {{"lo", {0, 0, 0}}, {"hi", {1, 1, 1}}};
    const auto e = load_errors(scene);
    REQUIRE(e.count("/stages/1/box_densty"));
    CHECK(e.at("/stages/1/box_densty").find("did you mean \"box_density\"") != std::string::npos);
  }
  SECTION("its columns are the stage's: a snapshot may watch one; a run reports every particle inside") {
    scene["stages"][1]["box_density"] = {{"lo", {-1, -1, -1}}, {"hi", {1, 1, 1}}};
    scene["stages"][1]["snapshots"] = {{"column", "box_solid_fraction"}, {"at", {2.0}}};
    CHECK(load_errors(scene).empty());
    scene["stages"][1].erase("snapshots");
    test::ScratchDir dir;
    const json summary = test::run_scene(scene, SPARKDEM_SOURCE_DIR, dir.path / "out");
    const json& fin = summary["stages"][1]["final"];
    CHECK(fin["box_particles"].get<double>() == fin["particles"].get<double>());
    // A 6 x 6 x 8 lattice of 2 mm spheres, none reaching a box face: N (4/3) pi r^3 / (2 m)^3.
    const double n = fin["particles"].get<double>(), rr = 0.001;
    CHECK(fin["box_solid_fraction"].get<double>() == Approx(n * 4.0 / 3.0 * std::numbers::pi * rr * rr * rr / 8.0).epsilon(1e-12));
  }
}

}  // namespace test_box_density
