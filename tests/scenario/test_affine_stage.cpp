// The stage key `affine` (engine/state/affine_map.hpp) in a scenario: a zero-step stage maps the
// relaxed box packing and its six walls by x -> o + diag(s) (x - o) exactly (closed form on every
// particle and wall), and bad input is a ConfigError at its JSON path, all errors at once.
#include <catch2/catch.hpp>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "engine/core/error.hpp"
#include "io/restart/state_file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_affine_stage {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json mapped_scene(const json& affine) {
  json j = test::load_data("gen_relax_small.json");
  j["stages"].push_back({{"name", "map"}, {"type", "dynamics"}, {"dt_fraction", 0.3}, {"affine", affine}, {"stop", {{"steps", 0}}}});
  return j;
}

State run_to(const json& scene, const fs::path& out) {
  (void)test::run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data", out);
  State s;
  io::read_checkpoint(out / "final_state.h5", s);
  return s;
}
}  // namespace

TEST_CASE("affine stage: a zero-step stage maps the packing and its walls exactly", "[affine][scenario]") {
  const test::ScratchDir dir("affine_stage");
  json packed = test::load_data("gen_relax_small.json");
  const State before = run_to(packed, dir.path / "packed");
  const Vec3 o(0.005, 0.005, 0.0), S(0.95, 0.95, 0.9);
  const State after = run_to(mapped_scene({{"scale", {0.95, 0.95, 0.9}}, {"origin", {0.005, 0.005, 0.0}}}), dir.path / "mapped");
  REQUIRE(after.particles.size() == before.particles.size());
  for (std::size_t i = 0; i < before.particles.size(); ++i) {
    REQUIRE(after.particles.id[i] == before.particles.id[i]);
    CHECK((after.particles.position[i] - (o + S.cwiseProduct(before.particles.position[i] - o))).norm() <= 1e-17);
    CHECK(after.particles.radius[i] == before.particles.radius[i]);
  }
  // Each wall's distance to each particle scales with the map across that wall (planes of the box).
  REQUIRE(after.walls.size() == before.walls.size());
  for (std::size_t k = 0; k < before.walls.size(); ++k)
    for (std::size_t i = 0; i < before.particles.size(); i += 37) {
      Vec3 n;
      double d0, d1;
      before.walls[k].distance(before.particles.position[i], n, d0);
      after.walls[k].distance(after.particles.position[i], n, d1);
      const double s = std::abs(n.dot(S));  // the normal is a coordinate axis
      CHECK(std::abs(d1 - s * d0) <= 1e-17);
    }
}

TEST_CASE("affine stage: bad scales, a missing component and a generator stage are errors at their paths", "[affine][config]") {
  json scene = mapped_scene({{"scale", {0.9, -1.0}}});
  scene["stages"][0]["affine"] = {{"scale", {0.9, 0.9, 0.9}}};
  try {
    (void)io::load_scenario(scene, test::registry(), ".");
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    std::vector<std::string> paths;
    for (const auto& d : e.diagnostics()) paths.push_back(d.path);
    CHECK(std::find(paths.begin(), paths.end(), "/stages/1/affine/scale") != paths.end());    // 2 numbers
    CHECK(std::find(paths.begin(), paths.end(), "/stages/1/affine/scale/1") != paths.end());  // -1
    CHECK(std::find(paths.begin(), paths.end(), "/stages/0/affine") != paths.end());          // with a generator
  }
}

}  // namespace test_affine_stage
