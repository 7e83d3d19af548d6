/// Crash safety of a run's outputs, through the `sparkdem` executable.
///
/// Invariants under test (README, "Outputs"; io/scenario/pipeline.hpp):
///  - after a SIGKILL at any moment, every frame that run.log reports as written is a complete,
///    readable frame file, identical bit for bit to the same frame of an uninterrupted run;
///  - checkpoint.h5, if present, passes its checksum, and `--restart` from it finishes and ends in
///    exactly the final_state.h5 of the uninterrupted run; if the log reports no checkpoint yet,
///    none may exist (at most its .tmp);
///  - the index files present (timeseries.csv, results.h5, results.xdmf) are complete: the time
///    series is a prefix of the uninterrupted run's, every frame results.h5 links opens;
///  - a damaged checkpoint given to --restart or "from_snapshot" ends the run with exit code 4 and
///    a message saying what is wrong.
/// The kill moments are drawn from a seeded generator; how they fall relative to the run's
/// progress depends on the machine, so the test counts what happened and requires a minimum of
/// runs killed mid-way and of restarts, so it cannot pass without exercising them.
#include <catch2/catch.hpp>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "engine/core/error.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using steady = std::chrono::steady_clock;

constexpr std::size_t kParticles = 64;       // the 4 x 4 x 4 lattice of crash_pour.json
constexpr std::int64_t kCheckpointEvery = 250;  // crash_pour.json, stage "pour"

fs::path scene_file() { return fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/crash_pour.json"; }

std::string read_text(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// How a child process ended.
struct Outcome {
  bool killed = false;  ///< by our SIGKILL
  int exit_code = -1;   ///< when it exited by itself
  double seconds = 0.0;
};

/// Starts `sparkdem args...` with one passive OpenMP thread, stdout discarded, stderr to `err`.
pid_t spawn_sparkdem(const std::vector<std::string>& args, const fs::path& err) {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string v = *e;
    if (v.rfind("OMP_NUM_THREADS=", 0) != 0 && v.rfind("OMP_WAIT_POLICY=", 0) != 0) env.push_back(v);
  }
  env.push_back("OMP_NUM_THREADS=1");
  env.push_back("OMP_WAIT_POLICY=PASSIVE");
  std::vector<std::string> argv{SPARKDEM_BINARY};
  argv.insert(argv.end(), args.begin(), args.end());
  std::vector<char*> argv_c, env_c;
  for (auto& a : argv) argv_c.push_back(a.data());
  argv_c.push_back(nullptr);
  for (auto& e : env) env_c.push_back(e.data());
  env_c.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  REQUIRE(posix_spawn_file_actions_init(&actions) == 0);
  REQUIRE(posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0) == 0);
  REQUIRE(posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644) == 0);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, SPARKDEM_BINARY, &actions, nullptr, argv_c.data(), env_c.data());
  posix_spawn_file_actions_destroy(&actions);
  REQUIRE(rc == 0);
  return pid;
}

Outcome wait_for(pid_t pid, steady::time_point start) {
  int status = 0;
  pid_t r;
  do {
    r = waitpid(pid, &status, 0);
  } while (r < 0 && errno == EINTR);
  REQUIRE(r == pid);
  Outcome o;
  o.seconds = std::chrono::duration<double>(steady::now() - start).count();
  if (WIFSIGNALED(status)) {
    INFO("sparkdem died of signal " << WTERMSIG(status));
    REQUIRE(WTERMSIG(status) == SIGKILL);
    o.killed = true;
  } else {
    REQUIRE(WIFEXITED(status));
    o.exit_code = WEXITSTATUS(status);
  }
  return o;
}

/// Runs sparkdem to its end.
Outcome run_sparkdem(const std::vector<std::string>& args, const fs::path& err) {
  const auto start = steady::now();
  const Outcome o = wait_for(spawn_sparkdem(args, err), start);
  if (o.exit_code != 0) UNSCOPED_INFO("sparkdem stderr: " << read_text(err));
  return o;
}

/// Runs sparkdem and sends it SIGKILL after `delay` (if it is still running then).
Outcome run_and_kill(const std::vector<std::string>& args, const fs::path& err, std::chrono::microseconds delay) {
  const auto start = steady::now();
  const pid_t pid = spawn_sparkdem(args, err);
  std::this_thread::sleep_until(start + delay);
  REQUIRE(kill(pid, SIGKILL) == 0);  // also succeeds on an exited, not yet reaped child
  return wait_for(pid, start);
}

/// A frame run.log reports as written.
struct ReportedFrame {
  std::string file;  ///< relative to the output directory
  std::int64_t step;
  std::string stage;
};

/// What one run (one "run started" section of run.log) reports.
struct RunReport {
  std::vector<ReportedFrame> frames;
  std::vector<std::int64_t> checkpoints;  ///< steps
  bool completed = false;
};

/// The runs recorded in a run.log, in order; only complete lines (ending in '\n') count.
std::vector<RunReport> parse_log(const fs::path& log) {
  static const std::regex frame(R"(^\[[^\]]*\] frame [0-9]{6} written: (\S+) \(step ([0-9]+), t = \S+ s, stage '([^']*)'\)$)");
  static const std::regex checkpoint(R"(^\[[^\]]*\] checkpoint written: checkpoint\.h5 \(step ([0-9]+), stage '[^']*'\)$)");
  std::vector<RunReport> runs;
  const std::string text = read_text(log);
  std::size_t pos = 0;
  for (std::size_t end = text.find('\n'); end != std::string::npos; pos = end + 1, end = text.find('\n', pos)) {
    const std::string line = text.substr(pos, end - pos);
    std::smatch m;
    if (line.find("] run started: ") != std::string::npos) {
      runs.emplace_back();
    } else if (std::regex_match(line, m, frame)) {
      REQUIRE(!runs.empty());
      runs.back().frames.push_back({m[1], std::stoll(m[2]), m[3]});
    } else if (std::regex_match(line, m, checkpoint)) {
      REQUIRE(!runs.empty());
      runs.back().checkpoints.push_back(std::stoll(m[1]));
    } else if (line.find("] run completed: ") != std::string::npos) {
      REQUIRE(!runs.empty());
      runs.back().completed = true;
    }
  }
  return runs;
}

using FrameKey = std::pair<std::string, std::int64_t>;  // stage, step

/// Every frame a run reports is complete and equal bit for bit to the reference run's frame of
/// the same stage and step. Returns the number of frames checked.
std::size_t check_reported_frames(const fs::path& dir, const RunReport& run, const fs::path& ref_dir,
                                  const std::map<FrameKey, std::string>& ref_frames) {
  for (const ReportedFrame& f : run.frames) {
    INFO("frame " << f.file << " of " << dir << " (step " << f.step << ", stage " << f.stage << ")");
    const fs::path file = dir / f.file;
    REQUIRE(fs::exists(file));
    const auto h5 = sparkdem::io::H5File::open_read(file);
    CHECK(h5.attribute_int64("/", "step") == f.step);
    CHECK(h5.attribute_string("/", "stage") == f.stage);
    for (const char* v : {"position", "velocity", "omega", "force"})
      CHECK(h5.shape(std::string("/particles/") + v) == std::vector<std::size_t>{kParticles, 3});
    for (const char* s : {"radius", "id", "material"})
      CHECK(h5.shape(std::string("/particles/") + s) == std::vector<std::size_t>{kParticles, 1});
    const auto pairs = h5.shape("/contacts/pairs");
    REQUIRE(pairs.size() == 2);
    CHECK(pairs[1] == 2);
    CHECK(h5.shape("/contacts/overlap") == std::vector<std::size_t>{pairs[0], 1});
    CHECK(h5.shape("/contacts/force") == std::vector<std::size_t>{pairs[0], 3});
    const auto ref = ref_frames.find({f.stage, f.step});
    REQUIRE(ref != ref_frames.end());
    sparkdem::test::require_identical_files(file, ref_dir / ref->second, {"particles/position", "contacts/pairs"});
  }
  return run.frames.size();
}

/// The step stored in a checkpoint (read through the verifying archive).
std::int64_t checkpoint_step(const fs::path& file) {
  sparkdem::io::Hdf5Archive ar = sparkdem::io::Hdf5Archive::for_reading(file);
  std::int64_t step = -1;
  ar.visit("state/step", step);
  return step;
}

std::vector<std::string> lines_of(const fs::path& file) {
  std::vector<std::string> lines;
  std::istringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

/// The index files present in `dir` are complete and consistent with the reference run.
void check_index_files(const fs::path& dir, const fs::path& ref_dir) {
  if (fs::exists(dir / "timeseries.csv")) {
    // Empty before the first time-series row, else the header and a prefix of the rows.
    const auto got = lines_of(dir / "timeseries.csv"), ref = lines_of(ref_dir / "timeseries.csv");
    REQUIRE(got.size() <= ref.size());
    CHECK(std::equal(got.begin(), got.end(), ref.begin()));
  }
  if (fs::exists(dir / "results.h5")) {
    const auto h5 = sparkdem::io::H5File::open_read(dir / "results.h5");
    for (const std::string& frame : h5.children("/frames"))
      CHECK(h5.shape("/frames/" + frame + "/particles/position") == std::vector<std::size_t>{kParticles, 3});
  }
  if (fs::exists(dir / "results.xdmf")) {
    const std::string xdmf = read_text(dir / "results.xdmf");
    CHECK(xdmf.size() > 8);
    CHECK(xdmf.substr(xdmf.size() - 8) == "</Xdmf>\n");
    static const std::regex item(R"((frames/frame_[0-9]{6}\.h5):/particles/)");
    for (auto it = std::sregex_iterator(xdmf.begin(), xdmf.end(), item); it != std::sregex_iterator(); ++it)
      CHECK(fs::exists(dir / (*it)[1].str()));
  }
}

bool has_tmp_file(const fs::path& dir) {
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.path().extension() == ".tmp") return true;
  return false;
}

}  // namespace

TEST_CASE("SIGKILL at 50 random moments: reported frames readable, last checkpoint verified and restarted bit-exactly",
          "[crash][scenario]") {
  sparkdem::test::ScratchDir tmp("sparkdem_crash");
  const std::string scene = scene_file().string();

  // The uninterrupted reference run.
  const fs::path ref = tmp.path / "ref";
  const Outcome r = run_sparkdem({"run", scene, "-o", ref.string(), "--quiet"}, tmp.path / "ref_stderr.txt");
  REQUIRE(r.exit_code == 0);
  const auto ref_runs = parse_log(ref / "run.log");
  REQUIRE(ref_runs.size() == 1);
  REQUIRE(ref_runs[0].completed);
  std::map<FrameKey, std::string> ref_frames;
  // (stage, step) names a state; a stage's last step can be written twice (its frame_every
  // frame and its closing frame), both of the same state.
  for (const ReportedFrame& f : ref_runs[0].frames) ref_frames.emplace(FrameKey{f.stage, f.step}, f.file);
  REQUIRE(ref_frames.size() >= 10);
  REQUIRE(ref_runs[0].checkpoints.size() >= 8);
  // Kill moments are drawn over the run's duration, taken as the shortest seen so far (the
  // reference run, or a trial that finished before its kill).
  double run_time = r.seconds;

  constexpr int kTrials = 50;
  std::mt19937 rng(20240601);
  std::uniform_real_distribution<double> fraction(0.0, 0.95);
  int killed = 0, completed = 0, killed_before_checkpoint = 0, restarted = 0, with_tmp = 0;
  std::size_t frames_checked = 0;
  for (int trial = 0; trial < kTrials; ++trial) {
    const fs::path dir = tmp.path / ("trial" + std::to_string(trial));
    const fs::path out = dir / "out";
    fs::create_directories(dir);
    const auto delay = std::chrono::duration_cast<std::chrono::microseconds>(
        std::chrono::duration<double>(run_time * fraction(rng)));
    const Outcome o = run_and_kill({"run", scene, "-o", out.string(), "--quiet"}, dir / "stderr.txt", delay);
    INFO("trial " << trial << ": killed after " << delay.count() << " us, " << (o.killed ? "killed" : "exited"));
    if (o.killed) ++killed;
    else {
      REQUIRE(o.exit_code == 0);
      ++completed;
      run_time = std::min(run_time, o.seconds);
    }
    if (!fs::exists(out / "run.log")) continue;  // killed before the log was created: nothing to check
    if (has_tmp_file(out)) ++with_tmp;

    // (a) Every reported frame is complete and right. (A run killed right after creating its log
    // has not reported anything, not even its start.)
    const auto runs = parse_log(out / "run.log");
    REQUIRE(runs.size() <= 1);
    const RunReport killed_run = runs.empty() ? RunReport{} : runs[0];
    frames_checked += check_reported_frames(out, killed_run, ref, ref_frames);
    check_index_files(out, ref);
    if (fs::exists(out / "final_state.h5")) CHECK_NOTHROW(sparkdem::io::read_verified_checkpoint(out / "final_state.h5"));

    // (b) The last checkpoint verifies and continues the run to the reference's final state.
    const fs::path ckpt = out / "checkpoint.h5";
    if (!fs::exists(ckpt)) {
      CHECK(killed_run.checkpoints.empty());  // nothing reported that is not there
      if (o.killed) ++killed_before_checkpoint;
      continue;
    }
    REQUIRE_NOTHROW(sparkdem::io::read_verified_checkpoint(ckpt));
    const std::int64_t step = checkpoint_step(ckpt);
    CHECK(step % kCheckpointEvery == 0);
    // A kill can fall between the rename and the log line: the file may be newer than the log says.
    if (!killed_run.checkpoints.empty()) CHECK(step >= killed_run.checkpoints.back());
    if (!o.killed) continue;
    // Restart in place (as a user would) on even trials, into a new directory on odd ones.
    const fs::path again = trial % 2 == 0 ? out : dir / "restart";
    const Outcome rr = run_sparkdem({"run", scene, "--restart", ckpt.string(), "-o", again.string(), "--quiet"},
                                    dir / "restart_stderr.txt");
    REQUIRE(rr.exit_code == 0);
    ++restarted;
    sparkdem::test::require_identical_state(ref / "final_state.h5", again / "final_state.h5");
    const auto again_runs = parse_log(again / "run.log");
    REQUIRE(again_runs.size() == (trial % 2 == 0 ? runs.size() + 1 : 1u));
    CHECK(again_runs.back().completed);
    CHECK_FALSE(again_runs.back().frames.empty());
    frames_checked += check_reported_frames(again, again_runs.back(), ref, ref_frames);
    CHECK(sparkdem::io::H5File::open_read(again / "results.h5").children("/frames").size() == again_runs.back().frames.size());
    CHECK_FALSE(has_tmp_file(again));
  }
  WARN("crash trials: " << killed << " killed (" << killed_before_checkpoint << " before any checkpoint, " << with_tmp
                        << " with a half-written .tmp file left), " << completed << " finished first, " << restarted
                        << " restarted; " << frames_checked << " reported frames checked; reference run "
                        << r.seconds << " s");
  // Not vacuous: most runs were killed mid-way, and many were restarted.
  CHECK(killed + completed == kTrials);
  REQUIRE(killed >= 30);
  REQUIRE(restarted >= 15);
  REQUIRE(frames_checked >= 200);
}

TEST_CASE("a damaged checkpoint given to --restart or from_snapshot exits with code 4 and says what is wrong",
          "[crash][scenario]") {
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
    snap["stages"] = json::array({{{"name", "go"}, {"type", "dynamics"}, {"from_snapshot", file.string()}, {"dt", 2e-5},
                                   {"stop", {{"steps", 10}}}}});
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
