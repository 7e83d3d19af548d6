/// Fuzzing of the restart reader in CI: seeded mutations of genuine checkpoints, re-sealed with a
/// valid checksum header so they reach HDF5 and the archive reader, each restarted in a forked
/// child (the `--restart` path: io::run_scenario with RunOptions::restart). The machinery is in
/// tests/support/checkpoint_fuzz.hpp and checkpoint_mutator.hpp; tests/fuzz/fuzz_driver.cpp runs
/// the same cases at scale (tools/fuzz.sh).
/// Invariant: a restart from a mutated checkpoint completes or stops with a typed error
/// (SetupError, exit code 4; PhysicsError, exit code 3) within the time limit; never a crash, an
/// untyped exception (std::bad_alloc from a huge size, std::out_of_range, ...) or a hang.
/// The second test case replays, by recipe, the inputs that crashed the reader before it
/// validated what it reads.
#include <catch2/catch.hpp>

#include <cstdlib>
#include <functional>
#include <limits>
#include <filesystem>
#include <map>
#include <string>

#include "support/checkpoint_fuzz.hpp"
#include "support/mock_modules.hpp"
#include "support/scratch.hpp"

namespace test_fuzz_checkpoint {

namespace {

namespace fs = std::filesystem;
using namespace sparkdem;
using test::ChildResult;
namespace fuzz = test::fuzz;

const Registry& registry() {
  static const Registry reg = test::registry_with_mocks();
  return reg;
}

fs::path data_dir() { return fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data"; }

constexpr unsigned kTimeLimit = 20;  // [s] per case; an unmutated restart takes well under 1 s

}  // namespace

TEST_CASE("restart reader: seeded mutations of re-sealed checkpoints give a typed error or a completed run, never a crash or hang",
          "[fuzz][restart][scenario]") {
  test::ScratchDir tmp("sparkdem_fuzz_ckpt");
  // SPARKDEM_FUZZ_CHECKPOINTS overrides the number of cases per seed for longer exploration.
  const int per_seed = std::getenv("SPARKDEM_FUZZ_CHECKPOINTS") ? std::atoi(std::getenv("SPARKDEM_FUZZ_CHECKPOINTS")) : 60;
  int cases = 0, typed = 0, completed = 0;
  for (const char* name : {"crash_pour.json", "torsion_small.json", "cpc_small.json"}) {
    const fs::path dir = tmp.path / fs::path(name).stem();
    fs::create_directories(dir);
    fuzz::CkptSeed seed = fuzz::make_checkpoint_seed(registry(), data_dir(), name, dir, 20 * kTimeLimit);
    std::map<std::string, int> outcomes;
    for (int k = 0; k < per_seed; ++k) {
      const fs::path file = dir / "case.h5";
      std::string what;
      try {
        what = fuzz::write_mutated_checkpoint(seed, 0xc0ffee00ULL + static_cast<std::uint64_t>(k), file);
      } catch (const std::runtime_error&) {
        continue;  // HDF5 refused to write the mutated model: not a case
      }
      const ChildResult r = fuzz::restart_case(seed, file, dir / "out", kTimeLimit);
      ++cases;
      ++outcomes[fuzz::class_name(r)];
      if (r.kind == ChildResult::Kind::Exited && r.exit_code == fuzz::kOk)
        ++completed;
      else if (!fuzz::is_bug(r))
        ++typed;
      INFO(name << ", case " << k << ": " << what << "\n-> " << fuzz::class_name(r) << "\n" << r.message);
      CHECK_FALSE(fuzz::is_bug(r));
    }
    std::string summary;
    for (const auto& [c, n] : outcomes) summary += c + " " + std::to_string(n) + ", ";
    WARN(name << ": " << summary);
  }
  // Not vacuous: most mutations reach the reader and are caught there; some are benign.
  CHECK(cases >= 150);
  CHECK(typed > cases / 3);
  CHECK(completed > 0);
}

TEST_CASE("restart reader: the mutated checkpoints that crashed, hung or threw untyped exceptions now give a SetupError",
          "[fuzz][restart][scenario]") {
  // Recipes of the cases found by tools/fuzz.sh before the reader checked what it reads (each
  // was a crash, a hang or an untyped exception; the fuzz case and seed scene are named).
  test::ScratchDir tmp("sparkdem_fuzz_regress");
  using Kind = test::CkptItem::Kind;
  struct Recipe {
    const char* what;
    std::function<void(test::CkptModel&)> mutate;
  };
  auto rows = [](test::CkptModel& m, const std::string& name, std::size_t r) {
    test::CkptItem& it = m.at(name);
    const std::size_t w = it.dims.size() >= 2 ? static_cast<std::size_t>(it.dims[1]) : 1;
    it.dims[0] = r;
    if (it.kind == Kind::Float)
      it.f.resize(r * w, it.f.empty() ? 0.0 : it.f[0]);
    else
      it.i.resize(r * w, it.i.empty() ? 0 : it.i[0]);
  };
  const std::vector<Recipe> pour = {
      {"huge dataset declared, never written (was std::bad_alloc / std::length_error)",
       [](test::CkptModel& m) {
         m.at("state/particles/position").dims = {hsize_t{1} << 40, 3};
         m.at("state/particles/position").unwritten = true;
       }},
      {"a radius set to 0 (was SIGSEGV in the neighbour grid)", [](test::CkptModel& m) { m.at("state/particles/radius").f[0] = 0.0; }},
      {"particle ids with twice the rows of the other arrays (was SIGABRT)",
       [&](test::CkptModel& m) { rows(m, "state/particles/id", 2 * m.at("state/particles/id").i.size()); }},
      {"stage start step moved past the step (was a hang: the stage ran for ever)",
       [](test::CkptModel& m) { m.at("state/stage_step0").i[0] = std::int64_t{1} << 31; }},
      {"stage time step divided by 1e10 (was a hang)", [](test::CkptModel& m) { m.at("state/stage_dt").f[0] *= 1e-10; }},
      {"field list replaced by bytes that are not a list (was std::invalid_argument from stoi)",
       [](test::CkptModel& m) { m.at("state/particles/fields/_list").s = "x|y|z|w\n"; }},
      {"field list with a huge component count (was a hang)",
       [](test::CkptModel& m) { m.at("state/particles/fields/_list").s = "a|9999|u|1\n"; }},
      {"a wall geometry with 0 rows (was SIGSEGV)", [&](test::CkptModel& m) { rows(m, "state/walls/floor/geometry", 0); }},
      {"a contact hand-over key without its count (was SIGSEGV)",
       [&](test::CkptModel& m) {
         test::CkptItem& k = m.at("state/contacts/handover/keys");
         k.kind = Kind::Int;
         k.dims = {1};
         k.i = {5};
       }},
  };
  const std::vector<Recipe> hot_press = {
      {"a reference radius set to inf (was SIGSEGV: thermal expansion made the radius inf)",
       [](test::CkptModel& m) { m.at("state/particles/fields/radius_ref").f[23] = std::numeric_limits<double>::infinity(); }},
  };
  const std::vector<Recipe> torsion = {
      {"a scheduler mark renamed (was std::out_of_range from map::at)",
       [](test::CkptModel& m) {
         std::string& s = m.at("state/marks/names").s;
         const auto at = s.find("/broken");
         REQUIRE(at != std::string::npos);
         s[at + 1] = 'B';
       }},
  };
  for (const auto& [name, recipes] :
       {std::pair{"crash_pour.json", pour}, std::pair{"torsion_small.json", torsion}, std::pair{"hot_press_small.json", hot_press}}) {
    const fs::path dir = tmp.path / fs::path(name).stem();
    fs::create_directories(dir);
    fuzz::CkptSeed seed = fuzz::make_checkpoint_seed(registry(), data_dir(), name, dir, 20 * kTimeLimit);
    for (const Recipe& r : recipes) {
      test::CkptModel m = seed.model;
      r.mutate(m);
      const fs::path file = dir / "case.h5";
      test::write_checkpoint_model(m, file);
      const ChildResult res = fuzz::restart_case(seed, file, dir / "out", kTimeLimit);
      INFO(name << ": " << r.what << "\n-> " << fuzz::class_name(res) << "\n" << res.message);
      // The marks case may legitimately complete (a lost mark only makes the module run again).
      if (std::string(r.what).rfind("a scheduler mark", 0) == 0)
        CHECK_FALSE(fuzz::is_bug(res));
      else if (std::string(r.what).rfind("a reference radius", 0) == 0)
        CHECK(fuzz::class_name(res) == "PhysicsError");
      else
        CHECK(fuzz::class_name(res) == "SetupError");
    }
  }
}

}  // namespace test_fuzz_checkpoint
