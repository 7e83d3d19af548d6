/// A stage's "delete_sets" (LAMMPS `delete_atoms region`): the members of the named particle sets
/// at the stage start are deleted, the count goes to summary.json, the run continues, the stage
/// is checkpoint-safe, and an unknown set is a configuration error at its JSON path.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "engine/core/error.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

namespace test_delete_sets {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json run(const json& scene, const fs::path& out, const std::optional<fs::path>& restart = {}) {
  io::Scenario sc = io::load_scenario(scene, test::registry(), fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  io::RunOptions opt;
  opt.outdir = out;
  opt.restart = restart;
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}

/// gen_relax_small (300 particles in a 10 mm box) with two slot sets cut from the faces x = 0 and
/// x = 10 mm (3 mm deep, z in [4, 6] mm, through y), an electrode set, and after the relax
/// stage a stage "cut" that deletes the slots (steps 0) and a stage "fall" under gravity.
json notched_scene() {
  json j = test::load_data("gen_relax_small.json");
  j["particle_sets"] = {{"slot_left", {{"type", "box"}, {"lo", {-1, -1, 0.004}}, {"hi", {0.003, 1, 0.006}}}},
                        {"slot_right", {{"type", "box"}, {"lo", {0.007, -1, 0.004}}, {"hi", {1, 1, 0.006}}}},
                        {"floor", {{"type", "bottom_layer"}, {"thickness", 0.001}}}};
  j["stages"].push_back(
      {{"name", "cut"}, {"type", "dynamics"}, {"dt_fraction", 0.3}, {"delete_sets", {"slot_left", "slot_right"}}, {"stop", {{"steps", 0}}}});
  j["stages"].push_back({{"name", "fall"},
                         {"type", "dynamics"},
                         {"dt_fraction", 0.3},
                         {"sets", {"floor"}},
                         {"modules", {{"gravity", {{"acceleration", {0, 0, -9.81}}}}}},
                         {"stop", {{"steps", 400}}}});
  return j;
}

std::size_t count_in(const State& s, double x0, double x1, double z0, double z1) {
  std::size_t n = 0;
  for (const auto& x : s.particles.position)
    if (x.x() >= x0 && x.x() <= x1 && x.z() >= z0 && x.z() <= z1) ++n;
  return n;
}
}  // namespace

TEST_CASE("delete_sets removes the slot particles, reports the count and the run continues", "[delete][sets][scenario]") {
  test::ScratchDir tmp("sparkdem_delete_sets");
  // The relaxed packing alone: how many centres lie in each slot before the cut.
  json relax_only = test::load_data("gen_relax_small.json");
  run(relax_only, tmp.path / "R");
  State before;
  io::read_checkpoint(tmp.path / "R" / "final_state.h5", before);
  const std::size_t left = count_in(before, -1, 0.003, 0.004, 0.006), right = count_in(before, 0.007, 1, 0.004, 0.006);
  REQUIRE(before.particles.size() == 300);
  REQUIRE(left > 5);
  REQUIRE(right > 5);

  // Relax + cut: the state after the cut has no centre in either slot and every other particle.
  json cut_only = notched_scene();
  cut_only["stages"].erase(2);
  const json sc = run(cut_only, tmp.path / "C");
  State after;
  io::read_checkpoint(tmp.path / "C" / "final_state.h5", after);
  CHECK(after.particles.size() == 300 - left - right);
  CHECK(count_in(after, -1, 0.003, 0.004, 0.006) == 0);
  CHECK(count_in(after, 0.007, 1, 0.004, 0.006) == 0);
  const json& d = sc["stages"][1]["deleted_particles"];
  CHECK(d["total"].get<std::size_t>() == left + right);
  CHECK(d["sets"]["slot_left"].get<std::size_t>() == left);
  CHECK(d["sets"]["slot_right"].get<std::size_t>() == right);
  CHECK(d["contacts_removed"].get<std::size_t>() > 0);
  CHECK(sc["stages"][1]["particles"].get<std::size_t>() == 300 - left - right);
  // Tables of the state after the cut: rows point at existing particles with their ids.
  for (const PairRows* t : {static_cast<const PairRows*>(&after.contacts), static_cast<const PairRows*>(&after.bonds)})
    for (std::size_t r = 0; r < t->size(); ++r) {
      CHECK(after.particles.id[t->i(r)] == t->id_i()[r]);
      CHECK(after.particles.id[t->j(r)] == t->id_j()[r]);
    }
  // Survivors are untouched: the same ids at the same positions as before the cut.
  std::size_t k = 0;
  for (std::size_t i = 0; i < before.particles.size() && k < after.particles.size(); ++i)
    if (before.particles.id[i] == after.particles.id[k]) {
      CHECK(before.particles.position[i] == after.particles.position[k]);
      ++k;
    }
  CHECK(k == after.particles.size());

  // The full scene runs on after the cut (a dynamics stage under gravity with a set).
  const json sf = run(notched_scene(), tmp.path / "F");
  CHECK(sf["status"] == "completed");
  CHECK(sf["stages"][2]["steps"].get<std::int64_t>() == 400);
  CHECK(sf["stages"][2]["particles"].get<std::size_t>() == 300 - left - right);
  CHECK(sf["stages"][2].count("deleted_particles") == 0);
}

TEST_CASE("delete_sets: a restart inside the deleting stage ends bit for bit in the uninterrupted state", "[delete][restart][scenario]") {
  test::ScratchDir tmp("sparkdem_delete_restart");
  json scene = notched_scene();
  scene["stages"].erase(1);  // the falling stage deletes the slots itself
  scene["stages"][1]["delete_sets"] = {"slot_left", "slot_right"};
  const json a = run(scene, tmp.path / "A");
  json split = scene;
  split["stages"][1]["output"]["checkpoint_every"] = 250;  // global steps: lands inside "fall"
  run(split, tmp.path / "B");
  const fs::path ckpt = tmp.path / "B" / "checkpoint.h5";
  REQUIRE(fs::exists(ckpt));
  State mid;
  const auto [stage, inside] = io::read_checkpoint(ckpt, mid);
  REQUIRE(stage == 1);
  REQUIRE(inside);
  const json c = run(scene, tmp.path / "C", ckpt);
  CHECK(c["status"] == "completed");
  test::require_identical_state(tmp.path / "A" / "final_state.h5", tmp.path / "C" / "final_state.h5", {"pipeline/record"});
  // The resumed stage reports the deletion made before the checkpoint.
  CHECK(c["stages"][0]["deleted_particles"] == a["stages"][1]["deleted_particles"]);
  CHECK(a["stages"][1]["deleted_particles"]["total"].get<std::size_t>() > 10);
}

TEST_CASE("delete_sets: an unknown set is a configuration error at its path", "[delete][config]") {
  json scene = notched_scene();
  scene["stages"][1]["delete_sets"] = {"slot_left", "slot_rigth"};
  try {
    (void)io::load_scenario(scene, test::registry(), ".");
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    REQUIRE(e.diagnostics().size() == 1);
    CHECK(e.diagnostics()[0].path == "/stages/1/delete_sets/1");
    const std::string& m = e.diagnostics()[0].message;
    CHECK(m.find("expected the name of a particle set in /particle_sets") != std::string::npos);
    CHECK(m.find("found \"slot_rigth\"") != std::string::npos);
    CHECK(m.find("did you mean \"slot_right\"") != std::string::npos);
  }
  scene["stages"][1]["delete_sets"] = "slot_left";
  try {
    (void)io::load_scenario(scene, test::registry(), ".");
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    REQUIRE(e.diagnostics().size() == 1);
    CHECK(e.diagnostics()[0].path == "/stages/1/delete_sets");
  }
}

}  // namespace test_delete_sets
