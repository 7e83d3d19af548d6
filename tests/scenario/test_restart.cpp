/// Restart and thread-count determinism, through the `sparkdem` executable.
///
/// Invariant under test (bit-exactness is the point, so every comparison is memcmp of the
/// stored bytes): a run interrupted by a mid-stage checkpoint and continued with --restart ends
/// in exactly the final_state.h5 of the uninterrupted run, and so does a run with 2 threads
/// (per-contact forces are gathered per particle in a fixed order, see contact_table.hpp).
/// Every dataset of final_state.h5 is compared: particle positions, velocities, omegas,
/// orientations, forces, torques, the contact rows with their history (/state/contacts/state),
/// the wall history fields, walls, Verlet reference, step, time and the RNG.
#include <catch2/catch.hpp>

#include "support/h5compare.hpp"
#include "support/scratch.hpp"
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/hdf5/h5file.hpp"

namespace test_restart {

namespace {
using sparkdem::test::load_data;
using sparkdem::test::write_scene;

namespace fs = std::filesystem;
using nlohmann::json;

struct ScratchDir : sparkdem::test::ScratchDir {
  ScratchDir() : sparkdem::test::ScratchDir("sparkdem_restart") {}
};

/// Runs `sparkdem <args>` with OMP_NUM_THREADS=threads (and the environment assignments `env`, each
/// followed by a space); returns the exit code.
int run_cli(const std::string& args, int threads, const fs::path& dir, const std::string& env = "") {
  const std::string cmd = env + "OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=" + std::to_string(threads) + " '" + std::string(SPARKDEM_BINARY) +
                          "' " + args + " > '" + (dir / "stdout.txt").string() + "' 2> '" + (dir / "stderr.txt").string() + "'";
  const int rc = std::system(cmd.c_str());
  if (rc == -1 || !WIFEXITED(rc)) return -1;
  const int code = WEXITSTATUS(rc);
  if (code != 0) {
    std::ifstream e(dir / "stderr.txt");
    UNSCOPED_INFO("sparkdem " << args << " -> " << code << "; stderr: " << std::string(std::istreambuf_iterator<char>(e), {}));
  }
  return code;
}


/// Largest |shear displacement| in the contact history: proves the friction history is exercised.
double max_shear(const fs::path& file) {
  const auto f = sparkdem::io::H5File::open_read(file);
  double m = 0.0;
  for (double x : f.read_doubles("/state/contacts/state")) m = std::max(m, std::abs(x));
  return m;
}

std::int64_t stored_int(const fs::path& file, const std::string& name) { return sparkdem::io::H5File::open_read(file).read_int64(name); }

json summary_of(const fs::path& dir) {
  std::ifstream in(dir / "summary.json");
  return json::parse(in);
}

}  // namespace

TEST_CASE("restart from a mid-stage checkpoint reproduces the frictional pour bit for bit", "[restart][scenario]") {
  ScratchDir tmp;
  // 6x6x8 lattice of 2 mm spheres, lammps_hertz_tsuji with friction 0.5, tilted floor and tilted
  // gravity, spatial sort every 2 rebuilds, 3000 steps. Its `until` (no pair contact after
  // 0.03 s) never holds in the uninterrupted run; it is checked every 100 steps, so it is also
  // checked right after the restart at step 1700: a regression guard for restoring the
  // per-contact overlaps the monitors read.
  json scene = load_data("restart_pour.json");
  scene["stages"][1]["until"] = {{"contacts", {{"below", 1}}}, {"time", {{"above", 0.03}}}};
  const fs::path plain = write_scene(tmp.path, "plain.json", scene);
  scene["stages"][1]["output"]["checkpoint_every"] = 1700;  // global steps: one checkpoint, mid-stage
  const fs::path ckpt = write_scene(tmp.path, "ckpt.json", scene);
  const fs::path A = tmp.path / "A", B = tmp.path / "B", C = tmp.path / "C";

  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(plain) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet", 1, tmp.path) == 0);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(ckpt) + " -o " + sparkdem::test::shell_quoted(B) + " --quiet", 1, tmp.path) == 0);
  REQUIRE(fs::exists(B / "checkpoint.h5"));
  // The checkpoint lies inside the pour stage (stage 1), at global step 1700 of 3000.
  CHECK(stored_int(B / "checkpoint.h5", "/state/step") == 1700);
  CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == 1);
  CHECK(stored_int(B / "checkpoint.h5", "/pipeline/in_stage") == 1);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(ckpt) + " --restart " + sparkdem::test::shell_quoted(B / "checkpoint.h5") + " -o " + sparkdem::test::shell_quoted(C) + " --quiet", 1, tmp.path) == 0);

  CHECK(summary_of(A)["steps"] == 3000);
  CHECK(summary_of(C)["stages"].back()["steps"] == 3000);  // stage steps counted from the stage start
  CHECK(stored_int(C / "final_state.h5", "/state/step") == 3000);
  // Friction is active: tangential history of at least 1e-9 m (overlaps are ~1e-5 m here).
  CHECK(max_shear(A / "final_state.h5") > 1e-9);
  sparkdem::test::require_identical_state(A / "final_state.h5", B / "final_state.h5");  // writing a checkpoint changes nothing
  sparkdem::test::require_identical_state(A / "final_state.h5", C / "final_state.h5");
}

TEST_CASE("one and two threads give bit-identical frictional pours", "[restart][threads][scenario]") {
  // 288 particles: below the minimum item counts of engine/core/parallel.hpp, so the loops are
  // forced onto the team (SPARKDEM_PARALLEL_MIN_ITEMS=1) for the two-thread run to be parallel.
  ScratchDir tmp;
  const fs::path scene = fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/restart_pour.json";
  const fs::path A = tmp.path / "one", B = tmp.path / "two";
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(scene) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet --threads 1", 1, tmp.path) == 0);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(scene) + " -o " + sparkdem::test::shell_quoted(B) + " --quiet --threads 2", 2, tmp.path, "SPARKDEM_PARALLEL_MIN_ITEMS=1 ") == 0);
  CHECK(summary_of(A)["threads"] == 1);
  CHECK(summary_of(B)["threads"] == 2);
  CHECK(max_shear(A / "final_state.h5") > 1e-9);
  sparkdem::test::require_identical_state(A / "final_state.h5", B / "final_state.h5");
}

TEST_CASE("multi-stage restart: checkpoints in the first and in the second dynamics stage", "[restart][scenario]") {
  ScratchDir tmp;
  // lattice -> pour (1800 steps, hertz_mindlin, friction 0.5) -> push (1500 steps, moving wall
  // xlo, mass scaling 2, different dt). checkpoint_every counts global steps: 1100 lands in the
  // pour (stage step 1100), 2300 in the push (stage step 500).
  const json base = load_data("restart_two_stage.json");
  const fs::path plain = write_scene(tmp.path, "plain.json", base);
  const fs::path A = tmp.path / "A";
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(plain) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet", 1, tmp.path) == 0);
  CHECK(summary_of(A)["steps"] == 3300);
  CHECK(max_shear(A / "final_state.h5") > 1e-9);

  struct Case {
    int stage;
    int every;
    std::int64_t stage_step0;
  };
  for (const Case c : {Case{1, 1100, 0}, Case{2, 2300, 1800}}) {
    DYNAMIC_SECTION("checkpoint in stage " << c.stage << " at global step " << c.every) {
      json scene = base;
      scene["stages"][c.stage]["output"]["checkpoint_every"] = c.every;
      const fs::path f = write_scene(tmp.path, "ckpt" + std::to_string(c.stage) + ".json", scene);
      const fs::path B = tmp.path / ("B" + std::to_string(c.stage)), C = tmp.path / ("C" + std::to_string(c.stage));
      REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " -o " + sparkdem::test::shell_quoted(B) + " --quiet", 1, tmp.path) == 0);
      CHECK(stored_int(B / "checkpoint.h5", "/state/step") == c.every);
      CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == c.stage);
      CHECK(stored_int(B / "checkpoint.h5", "/state/stage_step0") == c.stage_step0);
      REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " --restart " + sparkdem::test::shell_quoted(B / "checkpoint.h5") + " -o " + sparkdem::test::shell_quoted(C) + " --quiet", 1, tmp.path) == 0);
      sparkdem::test::require_identical_state(A / "final_state.h5", C / "final_state.h5");
    }
  }
}

TEST_CASE("restart inside a fill stage: radius growth, wall history and until conditions", "[restart][scenario]") {
  ScratchDir tmp;
  // 60 spheres grown in a 4 mm box (the growth state lives in per-particle fields restored from
  // the checkpoint), then 500 steps under gravity. The fill stage stops on its `until`
  // conditions (growth complete, settled, small overlaps), checked every 50 steps.
  const json base = load_data("restart_fill.json");
  const fs::path A = tmp.path / "A", B = tmp.path / "B", C = tmp.path / "C";
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(write_scene(tmp.path, "plain.json", base)) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet", 1, tmp.path) == 0);
  const json cook = summary_of(A)["stages"][0];
  CHECK(cook["until_reached"] == true);  // the stop conditions, not the step budget, end the stage
  const std::int64_t n = cook["steps"].get<std::int64_t>();
  // One checkpoint at about 3/4 of the stage, on a check_every boundary: the `until` check right
  // after the restart sees the restored state.
  const std::int64_t every = std::max<std::int64_t>(50, 3 * n / 4 / 50 * 50);
  json scene = base;
  scene["stages"][0]["output"]["checkpoint_every"] = every;
  const fs::path f = write_scene(tmp.path, "ckpt.json", scene);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " -o " + sparkdem::test::shell_quoted(B) + " --quiet", 1, tmp.path) == 0);
  CHECK(stored_int(B / "checkpoint.h5", "/state/step") == every);
  CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == 0);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " --restart " + sparkdem::test::shell_quoted(B / "checkpoint.h5") + " -o " + sparkdem::test::shell_quoted(C) + " --quiet", 1, tmp.path) == 0);
  CHECK(summary_of(C)["stages"][0]["steps"] == n);
  sparkdem::test::require_identical_state(A / "final_state.h5", C / "final_state.h5");
}

TEST_CASE("restart from a checkpoint at a stage's last step writes the uninterrupted closing frame", "[restart][scenario]") {
  ScratchDir tmp;
  // The checkpoint falls on the pour's last step, so the resumed stage takes no step and writes its
  // closing frame from the restored state: its contact forces must be the stored ones (they were
  // zero before the contact table's per-row forces went into checkpoints).
  json scene = load_data("crash_pour.json");
  scene["stages"][1]["stop"] = {{"steps", 2000}};
  scene["stages"][1]["output"] = {{"frame_every", 0}, {"timeseries_every", 100}, {"checkpoint_every", 2000}};
  const fs::path f = write_scene(tmp.path, "scene.json", scene);
  const fs::path A = tmp.path / "A", C = tmp.path / "C";
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet", 1, tmp.path) == 0);
  CHECK(stored_int(A / "checkpoint.h5", "/state/step") == 2000);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " --restart " + sparkdem::test::shell_quoted(A / "checkpoint.h5") + " -o " + sparkdem::test::shell_quoted(C) + " --quiet", 1, tmp.path) == 0);
  // A: the lattice frame and the pour's closing frame; C: only the closing frame.
  const auto a = sparkdem::io::H5File::open_read(A / "results.h5");
  const auto c = sparkdem::io::H5File::open_read(C / "results.h5");
  REQUIRE(a.children("/frames") == std::vector<std::string>{"000000", "000001"});
  REQUIRE(c.children("/frames") == std::vector<std::string>{"000000"});
  CHECK(a.attribute_int64("/frames/000001", "step") == 2000);
  CHECK(c.attribute_int64("/frames/000000", "step") == 2000);
  const auto forces = c.read_doubles("/frames/000000/contacts/force");
  REQUIRE(!forces.empty());
  CHECK(std::any_of(forces.begin(), forces.end(), [](double x) { return x != 0.0; }));
  const auto same_bits = [](const std::vector<double>& x, const std::vector<double>& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  for (const char* d : {"particles/position", "particles/velocity", "particles/force", "contacts/overlap", "contacts/force"}) {
    INFO("dataset " << d);
    CHECK(same_bits(a.read_doubles(std::string("/frames/000001/") + d), c.read_doubles(std::string("/frames/000000/") + d)));
  }
  CHECK(a.read_int64s("/frames/000001/contacts/pairs") == c.read_int64s("/frames/000000/contacts/pairs"));
  sparkdem::test::require_identical_state(A / "final_state.h5", C / "final_state.h5");
}


TEST_CASE("restart in place from a checkpoint at a stage's last step keeps that step's frame once", "[restart][scenario]") {
  ScratchDir tmp;
  // The last step is also a frame step: the periodic frame is written, then the checkpoint
  // (which keeps it). Continued in place from that checkpoint, the stage takes no step, and its
  // closing frame must not repeat the kept one (found by the SIGKILL tests: 13 frames for 12).
  json scene = load_data("crash_pour.json");
  scene["stages"][1]["stop"] = {{"steps", 400}};
  scene["stages"][1]["output"] = {{"frame_every", 200}, {"timeseries_every", 100}, {"checkpoint_every", 400}};
  const fs::path f = write_scene(tmp.path, "scene.json", scene);
  const fs::path A = tmp.path / "A";
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " -o " + sparkdem::test::shell_quoted(A) + " --quiet", 1, tmp.path) == 0);
  CHECK(stored_int(A / "checkpoint.h5", "/state/step") == 400);
  const auto frames_before = sparkdem::io::H5File::open_read(A / "results.h5").children("/frames");
  // the lattice frame, then the pour's steps 0, 200 and 400 (its closing frame is step 400's)
  REQUIRE(frames_before.size() == 4);
  REQUIRE(run_cli("run " + sparkdem::test::shell_quoted(f) + " --restart " + sparkdem::test::shell_quoted(A / "checkpoint.h5") + " -o " +
                      sparkdem::test::shell_quoted(A) + " --quiet",
                  1, tmp.path) == 0);
  const auto a = sparkdem::io::H5File::open_read(A / "results.h5");
  CHECK(a.children("/frames") == frames_before);
  CHECK(a.attribute_int64("/frames/000003", "step") == 400);
  CHECK_FALSE(fs::exists(A / "frames" / "frame_000004.h5"));
}

}  // namespace test_restart
