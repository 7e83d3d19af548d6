/// "A scene pays only for what it uses": with no thermal or electrical module, preparing a stage
/// allocates no temperature or potential field, the contact table carries exactly the law's
/// history columns, and the step plan holds the core items plus the stage's own modules.
///
/// Invariant checked: the particle FieldRegistry after Simulation::prepare() equals, as a set,
/// the union of the fields declared by the active modules' Declarations; the law's wall history
/// (State::wall_history, when the law keeps per-contact state) holds one row per wall candidate,
/// not one per particle.
#include <catch2/catch.hpp>

#include "support/scratch.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "engine/model/registry.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/simulation.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace test_pays_nothing {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

const std::vector<std::string> kCorePlan = {"integrate_first_half", "walls", "neighbors", "contact_pairs", "contact_walls"};

std::vector<std::string> plan_with(const std::vector<std::string>& force_modules) {
  std::vector<std::string> p = kCorePlan;
  p.insert(p.end(), force_modules.begin(), force_modules.end());
  p.push_back("integrate_second_half");
  return p;
}

const Registry& registry() {
  static const Registry reg = [] {
    Registry r;
    physics::register_all(r);
    return r;
  }();
  return reg;
}

io::Scenario load(const json& j) { return io::load_scenario(j, registry(), SPARKDEM_SOURCE_DIR); }

json read_json(const fs::path& f) {
  std::ifstream in(f);
  REQUIRE(in);
  return json::parse(in);
}

/// Fields the modules declare; the law's wall history is not a particle field: its width is the
/// law's state columns and each wall has at most one row per candidate particle.
std::set<std::string> declared_fields(const State& s, const ContactModel& law, const std::vector<Module*>& mods) {
  std::set<std::string> f;
  CHECK(s.wall_history.width == static_cast<int>(law.state_columns().size()));
  if (s.wall_history.width > 0) {
    REQUIRE(s.wall_history.ids.size() == s.walls.size());
    for (std::size_t k = 0; k < s.walls.size(); ++k) {
      const std::size_t cand = k < s.wall_candidates.size() ? s.wall_candidates[k].size() : 0;
      CHECK(s.wall_history.ids[k].size() == cand);
      CHECK(s.wall_history.rows[k].size() == cand * static_cast<std::size_t>(s.wall_history.width));
    }
  }
  for (Module* m : mods) {
    Declarations d;
    m->declare(d);
    for (const auto& x : d.particle_fields) f.insert(x.name);
  }
  return f;
}

std::set<std::string> field_set(const State& s) {
  const auto n = s.particles.fields.names();
  return {n.begin(), n.end()};
}

/// Set up every stage of `sc` in order as io/scenario/pipeline.cpp does (generate, prepare),
/// without stepping; calls `check(stage index, state, simulation, modules)` after each prepare.
template <class F>
void prepare_stages(io::Scenario& sc, F check) {
  State s;
  s.materials = sc.materials;
  s.walls = sc.walls;
  s.rng.seed(sc.seed);
  for (std::size_t k = 0; k < sc.stages.size(); ++k) {
    io::StageDef& st = sc.stages[k];
    for (const auto& w : st.add_walls) s.walls.push_back(w);
    if (st.generator) st.generator->generate(s);
    Simulation sim(s, sc.law_of(st));
    std::vector<Module*> mods;
    for (auto& m : st.modules) {
      sim.add_module(m.get());
      mods.push_back(m.get());
    }
    sim.prepare(st.cfg);
    check(k, s, sim, mods);
  }
}

struct ScratchDir : sparkdem::test::ScratchDir {
  ScratchDir() : sparkdem::test::ScratchDir("sparkdem_pays") {}
};

}  // namespace

TEST_CASE("pour.json allocates only the law's wall history and plans only gravity", "[pays_nothing][scenario]") {
  io::Scenario sc = load(read_json(fs::path(SPARKDEM_SOURCE_DIR) / "configs/pour.json"));
  REQUIRE(sc.stages.size() == 2);
  int checked = 0;
  prepare_stages(sc, [&](std::size_t k, const State& s, const Simulation& sim, const std::vector<Module*>& mods) {
    INFO("stage " << k);
    const std::set<std::string> fields = field_set(s);
    CHECK(fields == declared_fields(s, sc.law_of(sc.stages[k]), mods));
    CHECK(fields.empty());
    CHECK(s.wall_history.width == 3);  // one shear vector per wall candidate
    CHECK(s.wall_history.ids.size() == 5);
    CHECK(s.contacts.state_columns() == std::vector<std::string>{"shear_x", "shear_y", "shear_z"});
    // Stage 0 (lattice) names no module; stage 1 (pour) names gravity only.
    CHECK(sim.plan().names() == (k == 0 ? plan_with({}) : plan_with({"gravity"})));
    ++checked;
  });
  CHECK(checked == 2);
}

TEST_CASE("a fill stage adds exactly the radius-growth fields and module", "[pays_nothing][scenario]") {
  json j = read_json(fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/restart_pour.json");
  j["walls"] = json::array();
  j["stages"] = json::array({{{"name", "fill"},
                              {"type", "fill"},
                              {"dt_fraction", 0.2},
                              {"generator", {{"shape", "box"}, {"lo", {0, 0, 0}}, {"hi", {0.01, 0.01, 0.01}}, {"particles", 40}}},
                              {"stop", {{"steps", 10}}}}});
  io::Scenario sc = load(j);
  prepare_stages(sc, [&](std::size_t, const State& s, const Simulation& sim, const std::vector<Module*>& mods) {
    const std::set<std::string> fields = field_set(s);
    CHECK(fields == declared_fields(s, *sc.law, mods));
    CHECK(fields == std::set<std::string>{"radius_growth/mass_final", "radius_growth/radius_final", "radius_growth/scale"});
    CHECK(s.particles.size() == 40);
    CHECK(sim.plan().names() == plan_with({"radius_growth"}));
  });
}

TEST_CASE("a short CLI pour stores and writes no optional field beyond the wall history", "[pays_nothing][scenario]") {
  ScratchDir tmp;
  json j = read_json(fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/restart_pour.json");
  j["stages"][1]["stop"] = {{"steps", 20}};
  j["stages"][1]["output"] = {{"frame_every", 10}, {"timeseries_every", 10}};
  // A third stage without modules: its plan must be the bare core.
  j["stages"].push_back({{"name", "coast"}, {"type", "dynamics"}, {"dt", 2e-5}, {"stop", {{"steps", 10}}}});
  const fs::path scene = tmp.path / "scene.json", out = tmp.path / "out";
  std::ofstream(scene) << j.dump(2);
  const std::string cmd = "OMP_NUM_THREADS=1 '" + std::string(SPARKDEM_BINARY) + "' run '" + scene.string() + "' -o '" + out.string() +
                          "' --quiet 2> '" + (tmp.path / "err.txt").string() + "'";
  const int rc = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(rc));
  REQUIRE(WEXITSTATUS(rc) == 0);

  const json summary = read_json(out / "summary.json");
  CHECK(summary["stages"][1]["step_plan"] == json(plan_with({"gravity"})));
  CHECK(summary["stages"][2]["step_plan"] == json(plan_with({})));

  // Checkpoint field list: "name|components|unit|output" per line; none. The wall history: one
  // shear vector per candidate of each of the five walls, fewer rows than particles.
  const auto fin = io::H5File::open_read(out / "final_state.h5");
  std::set<std::string> stored;
  const std::string list = fin.read_string("/state/particles/fields/_list");
  for (std::size_t pos = 0; pos < list.size();) {
    const std::size_t end = list.find('\n', pos);
    stored.insert(list.substr(pos, list.find('|', pos) - pos));
    pos = end + 1;
  }
  CHECK(stored.empty());
  const std::size_t particles = fin.shape("/state/particles/id").at(0);
  for (const char* w : {"floor", "xhi", "xlo", "yhi", "ylo"}) {
    const std::string g = std::string("/state/wall_history/") + w;
    CHECK(fin.shape(g + "/rows").at(0) == fin.shape(g + "/ids").at(0));
    CHECK(fin.shape(g + "/ids").at(0) == fin.shape(std::string("/state/wall_candidates/") + w).at(0));
    CHECK(fin.shape(g + "/ids").at(0) < particles);
  }

  // Result frames carry only the core particle quantities (the wall history is not an output).
  const auto res = io::H5File::open_read(out / "results.h5");
  const auto frames = res.children("/frames");
  REQUIRE(frames.size() >= 3);
  for (const auto& fr : frames) {
    const auto names = res.children("/frames/" + fr + "/particles");
    CHECK(std::set<std::string>(names.begin(), names.end()) ==
          std::set<std::string>{"force", "id", "material", "omega", "position", "radius", "velocity"});
  }
}

}  // namespace test_pays_nothing
