// Stage key create_bonds (issue 20): {"gap_tolerance_relative": g} bonds exactly the pairs that
// {"gap_tolerance": g x r_mean} bonds, r_mean the mean radius at the stage start, and reports the
// resolved gap; widening the gap only adds bonds. Scene: tests/scenario/data/tension_small.json
// (300 relaxed elements), the pull stage cut to one step.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "support/scratch.hpp"

namespace test_create_bonds {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

namespace {
/// tension_small with the pull stage's create_bonds replaced, one step long, the hold removed:
/// the pull stage's summary.
json pull_stage(const json& create_bonds, const std::string& tag) {
  const fs::path base = fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data";
  json scene = json::parse(std::ifstream(base / "tension_small.json"));
  scene["stages"].erase(2);
  scene["stages"][1]["create_bonds"] = create_bonds;
  scene["stages"][1]["stop"] = {{"steps", 1}};
  test::ScratchDir tmp("sparkdem_create_bonds_" + tag);
  const json summary = test::run_scene(scene, base, tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  return summary["stages"][1];
}
}  // namespace

TEST_CASE("create_bonds gap_tolerance_relative bonds the pairs of the absolute gap g x r_mean", "[bonds][scenario]") {
  const double g = 0.02;
  const json rel = pull_stage({{"gap_tolerance_relative", g}}, "rel");
  const double gap = rel["bonds_created_gap_m"].get<double>();
  const json cook = pull_stage({{"gap_tolerance", 0.0}}, "touch");
  // r_mean of the 300 elements of radius r (1 +- 0.125) filling the r = 1 mm, L = 4 mm cylinder at 0.63
  INFO("resolved gap " << gap << " m, bonds " << rel["bonds_created"] << " (touching pairs: " << cook["bonds_created"] << ")");
  CHECK(gap > g * 1.5e-4);
  CHECK(gap < g * 2.5e-4);
  const json abs = pull_stage({{"gap_tolerance", gap}}, "abs");
  CHECK(abs["bonds_created"] == rel["bonds_created"]);
  CHECK(rel["bonds_created"].get<int>() > cook["bonds_created"].get<int>());
}

}  // namespace test_create_bonds
