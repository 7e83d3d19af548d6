/// Crash safety of a run's outputs, through the `sparkdem` executable, on every scenario type.
///
/// Invariants under test (docs/running.md, "Outputs"; io/scenario/pipeline.hpp; the checks themselves are
/// in tests/support/crash_harness.hpp):
///  - after a SIGKILL at any moment, every frame that run.log reports as written is a complete,
///    readable frame file, identical bit for bit to the same frame of an uninterrupted run;
///  - checkpoint.h5, if present, passes its checksum, holds a step at which the uninterrupted run
///    also checkpointed, and `--restart` from it finishes and ends in exactly the final_state.h5 of
///    the uninterrupted run; if the log reports no checkpoint yet, none may exist (at most its .tmp);
///  - the index files present (timeseries.csv, results.h5, results.xdmf) are complete: the time
///    series is a prefix of the uninterrupted run's, every frame results.h5 links opens;
///  - a damaged checkpoint given to --restart or "from_snapshot" ends the run with exit code 4 and
///    a message saying what is wrong.
/// One small scene per scenario type (contact mechanics, packing generator, hot press with
/// sintering, electrical network with Joule heating and implicit heat conduction, explicit heat
/// conduction, cohesive beams in torsion, cpc fillers with percolation and ptc_strain, a multi-stage pipeline with mass scaling and a moving wall, and a
/// sweep), each with frames and checkpoints during its stages. The kill moments are drawn from a
/// seeded generator, stratified over the run's duration; how they fall relative to the run's
/// progress depends on the machine, so each type counts what happened and requires a minimum of
/// runs killed mid-way and of restarts, so it cannot pass without exercising them.
/// CI: 8 kill trials per type ("[crash]"); the full 50 per type are tagged [slow].
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "support/crash_harness.hpp"
#include "support/scratch.hpp"

namespace test_crash_safety {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem::test::crash;

fs::path scene_file() { return fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/crash_pour.json"; }

json data(const std::string& name) { return json::parse(read_text(fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data" / name)); }

/// Frames every `frames` steps and a checkpoint every `checkpoints` global steps in stage `k`.
json with_output(json j, int k, std::int64_t frames, std::int64_t checkpoints) {
  j["stages"][k]["output"]["frame_every"] = frames;
  j["stages"][k]["output"]["checkpoint_every"] = checkpoints;
  return j;
}

json with_steps(json j, int k, std::int64_t steps) {
  j["stages"][k]["stop"] = {{"steps", steps}};
  return j;
}

/// One scene per scenario type. The checkpoint periods have no common factor with the frame
/// periods, and each scene runs for roughly 0.5 to 2 s on one thread. (The cohesive-beam scene
/// spends about 40 % of its run in its relax packing stage, which writes no checkpoint: its kills
/// fall after that. The bonded tension test of the generic restart test is the same physics as
/// the torsion scene with one more stage, and is left out to keep CI short.)
struct CrashScene {
  const char* label;
  std::function<json()> scene;
  double kill_from = 0.1;  ///< kills fall in [kill_from, 0.95] of the run (after start-up, or after a long stage without checkpoints)
};

const std::vector<CrashScene>& crash_scenes() {
  static const std::vector<CrashScene> scenes = {
      {"pour: Hertz contacts, gravity, walls", [] { return data("crash_pour.json"); }},
      {"packing generator: deposit with settling and die contraction",
       [] { return with_output(with_steps(data("gen_deposit_small.json"), 0, 2000), 0, 250, 167); }},
      {"hot press: temperature_history, sintering, pressure servo, compact monitor",
       [] { return with_output(data("hot_press_small.json"), 1, 400, 333); }},
      {"Joule press: temperature_controller, electrical_network, implicit heat_conduction",
       [] { return with_output(with_steps(data("joule_press_small.json"), 1, 2000), 1, 200, 167); }},
      {"explicit heat_conduction on adaptive substeps with electrical_network",
       [] {
         json j = data("joule_press_small.json");
         auto& h = j["stages"][1]["modules"]["heat_conduction"];
         h["scheme"] = "explicit";
         h["model"] = "transmission_surface";
         h["touch_tolerance"] = 1e-5;
         h["density"] = 59.1;
         return with_output(with_steps(j, 1, 500), 1, 50, 41);
       }},
      {"cohesive beams twisted through bond failure: torsion_test, electrical_network on the bonds",
       [] { return with_output(with_steps(data("torsion_small.json"), 1, 800), 1, 80, 61); }, 0.4},
      {"cpc fillers, settling with electrical_network, contact_percolation and ptc_strain",
       [] { return with_output(with_steps(data("cpc_small.json"), 1, 400), 1, 40, 31); }},
      {"multi-stage pipeline: pour, then a wall push with mass scaling",
       [] {
         json j = with_output(with_steps(data("restart_two_stage.json"), 1, 900), 1, 150, 139);
         return with_output(with_steps(j, 2, 750), 2, 150, 139);
       }},
      {"dynamics taking snapshots, then a sweep over them and a stage after it",
       [] {
         json j = with_output(data("sweep_fall.json"), 1, 50, 37);
         return with_output(j, 3, 10, 37);
       }},
  };
  return scenes;
}

/// The kill trials of one scene type (every check of the outputs is inside kill_trials); returns
/// the counters, whose minimums the callers require so that a test cannot pass vacuously. Kill
/// moments are fractions of the reference run's duration: when the trials run slower than the
/// reference (machine load), kills land early and few leave a checkpoint, so another round of
/// `trials` (new seed) runs until the minimums are met, at most three rounds.
Counters crash_type(const CrashScene& c, int trials, int min_killed, int min_restarted) {
  sparkdem::test::ScratchDir tmp("sparkdem_crash");
  const fs::path scene = tmp.path / "scene.json";
  std::ofstream(scene) << c.scene().dump(2);
  const Reference ref = reference_run(scene, tmp.path / "ref", tmp.path);
  INFO(c.label << ": reference run " << ref.seconds << " s, " << ref.frames.size() << " frames, " << ref.checkpoint_steps.size()
               << " checkpoints");
  REQUIRE(ref.frames.size() >= 4);
  REQUIRE(ref.checkpoint_steps.size() >= 3);
  const auto seed = 20240601u + static_cast<std::uint32_t>(std::hash<std::string>{}(c.label) % 1000);
  Counters n;
  for (int round = 0; round < 3 && (n.killed < min_killed || n.restarted < min_restarted); ++round) {
    const fs::path dir = tmp.path / ("round" + std::to_string(round));
    fs::create_directories(dir);
    const Counters r = kill_trials(scene, ref, dir, trials, seed + 7919u * static_cast<std::uint32_t>(round), c.kill_from);
    WARN(c.label << ": round " << round << ", " << trials << " crash trials: " << r.text() << "; reference run " << ref.seconds << " s");
    n.trials += r.trials;
    n.killed += r.killed;
    n.completed += r.completed;
    n.killed_before_checkpoint += r.killed_before_checkpoint;
    n.restarted += r.restarted;
    n.with_tmp += r.with_tmp;
    n.frames_checked += r.frames_checked;
  }
  CHECK(n.killed + n.completed == n.trials);
  CHECK(n.frames_checked >= static_cast<std::size_t>(trials));
  return n;
}

}  // namespace

// CI: one test case per type (each a separate ctest entry, 5 to 20 s), 8 kill trials each.
TEST_CASE("SIGKILL at 8 random moments, pour: reported frames readable, last checkpoint restarted bit-exactly", "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(0), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, packing generator: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(1), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, hot press: reported frames readable, last checkpoint restarted bit-exactly", "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(2), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, Joule press: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(3), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
// This test found a lost-output bug: after a restart from a checkpoint taken after a solve with no
// particle-centred branch, the frames lacked the (empty) /networks/electrical group the
// uninterrupted run writes. electrical_network now checkpoints `branch_output`.
TEST_CASE("SIGKILL at 8 random moments, explicit heat conduction: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(4), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, cohesive beams in torsion: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(5), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, cpc percolation and ptc: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(6), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, multi-stage pipeline: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(7), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}
TEST_CASE("SIGKILL at 8 random moments, sweep: reported frames readable, last checkpoint restarted bit-exactly", "[crash][scenario]") {
  const Counters n = crash_type(crash_scenes().at(8), 8, 5, 2);
  CHECK(n.killed >= 5);     // killed mid-way
  CHECK(n.restarted >= 2);  // restarted from the last checkpoint and compared bit for bit
}

TEST_CASE("SIGKILL at 50 random moments of every scenario type: reported frames readable, last checkpoint restarted bit-exactly",
          "[crash][scenario][slow]") {
  for (const CrashScene& c : crash_scenes()) {
    DYNAMIC_SECTION(c.label) {
      const Counters n = crash_type(c, 50, 30, 15);
      CHECK(n.killed >= 30);
      CHECK(n.restarted >= 15);
    }
  }
}

TEST_CASE("a damaged checkpoint given to --restart or from_snapshot exits with code 4 and says what is wrong", "[crash][scenario]") {
  sparkdem::test::ScratchDir tmp("sparkdem_crash_cli");
  // A short run for a genuine checkpoint and final state.
  json j = json::parse(read_text(scene_file()));
  j["stages"][1]["stop"] = {{"steps", 300}};
  const fs::path scene = tmp.path / "scene.json";
  std::ofstream(scene) << j.dump(2);
  const fs::path good = tmp.path / "good";
  REQUIRE(run_sparkdem({"run", scene.string(), "-o", good.string(), "--quiet"}, tmp.path / "good_stderr.txt").exit_code == 0);
  std::ifstream in(good / "checkpoint.h5", std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), {});
  REQUIRE(bytes.size() > 1000);

  struct Damage {
    std::string name;
    std::vector<char> content;
    std::string message;
  };
  std::vector<Damage> cases;
  std::vector<char> flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  cases.push_back({"flipped.h5", flipped, "is corrupt: checksum mismatch"});
  cases.push_back({"truncated.h5", std::vector<char>(bytes.begin(), bytes.begin() + bytes.size() / 2),
                   "is truncated: " + std::to_string(bytes.size() / 2) + " bytes, its header says " + std::to_string(bytes.size())});
  cases.push_back({"empty.h5", {}, "is empty (0 bytes)"});
  std::mt19937 rng(99);
  std::vector<char> noise(5000);
  for (auto& c : noise) c = static_cast<char>(rng() & 0xff);
  cases.push_back({"noise.h5", noise, "is not a sparkdem checkpoint"});

  for (const Damage& d : cases) {
    const fs::path file = tmp.path / d.name;
    std::ofstream(file, std::ios::binary).write(d.content.data(), static_cast<std::streamsize>(d.content.size()));
    const std::string expected = "error: checkpoint '" + file.string() + "' " + d.message;
    INFO("damaged checkpoint " << d.name);
    {
      const fs::path out = tmp.path / ("restart_" + d.name);
      const Outcome o = run_sparkdem({"run", scene.string(), "--restart", file.string(), "-o", out.string(), "--quiet"},
                                     tmp.path / "stderr.txt");
      CHECK(o.exit_code == 4);
      CHECK_THAT(read_text(tmp.path / "stderr.txt"), Catch::Contains(expected));
      // The run log records why the run stopped; no result was started.
      CHECK_THAT(read_text(out / "run.log"), Catch::Contains("run failed: checkpoint '" + file.string() + "' " + d.message));
      CHECK_FALSE(fs::exists(out / "frames"));
    }
    json snap = j;
    snap["stages"] = json::array(
        {{{"name", "go"}, {"type", "dynamics"}, {"from_snapshot", file.string()}, {"dt", 2e-5}, {"stop", {{"steps", 10}}}}});
    const fs::path snap_scene = tmp.path / "snap.json";
    std::ofstream(snap_scene) << snap.dump(2);
    for (const auto& args : {std::vector<std::string>{"run", snap_scene.string(), "-o", (tmp.path / "snap_out").string()},
                             std::vector<std::string>{"check", snap_scene.string()}}) {
      INFO("sparkdem " << args[0] << " with from_snapshot");
      const Outcome o = run_sparkdem(args, tmp.path / "stderr.txt");
      CHECK(o.exit_code == 4);
      CHECK_THAT(read_text(tmp.path / "stderr.txt"), Catch::Contains(expected));
    }
  }
}

}  // namespace test_crash_safety
