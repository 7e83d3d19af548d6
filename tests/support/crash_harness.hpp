#pragma once
/// Machinery of the SIGKILL tests (tests/scenario/test_crash_safety.cpp): start the `sparkdem`
/// executable, kill it at a chosen moment, parse run.log, check every reported frame and the
/// index files against an uninterrupted reference run, verify the checkpoint left behind and
/// restart from it, and compare the final state bit for bit.
///
/// The invariants (docs/running.md, "Outputs"; io/scenario/pipeline.hpp):
///  - every frame that run.log reports as written is a complete, readable frame file, identical
///    bit for bit to the frame of the same stage and step of the uninterrupted run;
///  - checkpoint.h5, if present, passes its checksum, holds a step at which the uninterrupted
///    run also wrote a checkpoint, and `--restart` from it finishes in exactly the final_state.h5
///    of the uninterrupted run; if the log reports no checkpoint yet, none may exist;
///  - the index files present (timeseries.csv, results.h5, results.xdmf) are complete: the time
///    series is a prefix of the uninterrupted run's, every frame results.h5 links opens.
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
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/hdf5/h5file.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

extern char** environ;

namespace sparkdem::test::crash {

namespace fs = std::filesystem;
using steady = std::chrono::steady_clock;

inline std::string read_text(const fs::path& file) {
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
inline pid_t spawn_sparkdem(const std::vector<std::string>& args, const fs::path& err) {
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

inline Outcome wait_for(pid_t pid, steady::time_point start) {
  int status = 0;
  pid_t r;
  do { r = waitpid(pid, &status, 0); } while (r < 0 && errno == EINTR);
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
inline Outcome run_sparkdem(const std::vector<std::string>& args, const fs::path& err) {
  const auto start = steady::now();
  const Outcome o = wait_for(spawn_sparkdem(args, err), start);
  if (o.exit_code != 0) UNSCOPED_INFO("sparkdem stderr: " << read_text(err));
  return o;
}

/// Runs sparkdem and sends it SIGKILL after `delay` (if it is still running then).
inline Outcome run_and_kill(const std::vector<std::string>& args, const fs::path& err, std::chrono::microseconds delay) {
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
inline std::vector<RunReport> parse_log(const fs::path& log) {
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

/// The uninterrupted run of a scene.
struct Reference {
  fs::path dir;
  RunReport log;
  std::map<FrameKey, std::string> frames;  ///< (stage, step) -> frame file
  std::set<std::int64_t> checkpoint_steps;
  double seconds = 0.0;
};

/// Every frame a run reports is a readable frame of its stage and step, equal bit for bit to the
/// reference run's frame of the same stage and step. Returns the number of frames checked.
inline std::size_t check_reported_frames(const fs::path& dir, const RunReport& run, const Reference& ref) {
  for (const ReportedFrame& f : run.frames) {
    INFO("frame " << f.file << " of " << dir << " (step " << f.step << ", stage " << f.stage << ")");
    const fs::path file = dir / f.file;
    REQUIRE(fs::exists(file));
    const auto h5 = sparkdem::io::H5File::open_read(file);
    CHECK(h5.attribute_int64("/", "step") == f.step);
    CHECK(h5.attribute_string("/", "stage") == f.stage);
    const auto pos = h5.shape("/particles/position");
    REQUIRE(pos.size() == 2);
    CHECK(pos[1] == 3);
    const auto r = ref.frames.find({f.stage, f.step});
    REQUIRE(r != ref.frames.end());
    require_identical_files(file, ref.dir / r->second, {"particles/position"});
  }
  return run.frames.size();
}

/// The step stored in a checkpoint (read through the verifying archive).
inline std::int64_t checkpoint_step(const fs::path& file) {
  sparkdem::io::Hdf5Archive ar = sparkdem::io::Hdf5Archive::for_reading(file);
  std::int64_t step = -1;
  ar.visit("state/step", step);
  return step;
}

inline std::vector<std::string> lines_of(const fs::path& file) {
  std::vector<std::string> lines;
  std::istringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

/// The index files present in `dir` are complete and consistent with the reference run.
inline void check_index_files(const fs::path& dir, const fs::path& ref_dir) {
  if (fs::exists(dir / "timeseries.csv")) {
    // Empty before the first time-series row, else the header and a prefix of the rows, equal
    // cell for cell except the wall-clock columns ("*_solve_time", e.g. electrical_solve_time),
    // which differ between any two runs.
    const auto got = lines_of(dir / "timeseries.csv"), ref = lines_of(ref_dir / "timeseries.csv");
    REQUIRE(got.size() <= ref.size());
    auto cells = [](const std::string& line) {
      std::vector<std::string> c;
      std::stringstream ss(line);
      for (std::string x; std::getline(ss, x, ',');) c.push_back(x);
      return c;
    };
    std::vector<bool> wall_clock;
    for (std::size_t r = 0; r < got.size(); ++r) {
      const auto a = cells(got[r]), b = cells(ref[r]);
      INFO("timeseries.csv line " << r + 1 << " of " << dir);
      REQUIRE(a.size() == b.size());
      if (r == 0) {
        CHECK(a == b);
        for (const auto& name : a) wall_clock.push_back(name.size() > 11 && name.substr(name.size() - 11) == "_solve_time");
        continue;
      }
      for (std::size_t k = 0; k < a.size(); ++k)
        if (k >= wall_clock.size() || !wall_clock[k]) CHECK(a[k] == b[k]);
    }
  }
  if (fs::exists(dir / "results.h5")) {
    const auto h5 = sparkdem::io::H5File::open_read(dir / "results.h5");
    if (h5.exists("/frames"))
      for (const std::string& frame : h5.children("/frames")) {
        const auto shape = h5.shape("/frames/" + frame + "/particles/position");
        CHECK(shape.size() == 2);
      }
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

/// The half-written (".tmp") files under dir, relative to it.
inline std::vector<std::string> tmp_files(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.path().extension() == ".tmp") out.push_back(fs::relative(e.path(), dir).string());
  return out;
}
inline bool has_tmp_file(const fs::path& dir) { return !tmp_files(dir).empty(); }

/// /pipeline/record of a state file with every string that is a path reduced to its file name
/// (records name snapshot and sweep outputs by absolute path, which differ between directories),
/// without the output folder's bookkeeping ("outputs", "sweep_outputs": frame and row counts, the
/// summary's stage entries with their wall times), which describes a folder, not the state.
inline nlohmann::json record_without_paths(const fs::path& file) {
  sparkdem::io::Hdf5Archive ar = sparkdem::io::Hdf5Archive::for_reading(file);
  if (!ar.has("pipeline/record")) return nullptr;
  std::string text;
  ar.visit("pipeline/record", text);
  nlohmann::json j = nlohmann::json::parse(text);
  std::function<void(nlohmann::json&)> strip = [&](nlohmann::json& x) {
    if (x.is_string() && x.get<std::string>().find('/') != std::string::npos)
      x = fs::path(x.get<std::string>()).filename().string();
    else if (x.is_structured())
      for (auto& y : x) strip(y);
  };
  strip(j);
  if (j.is_object()) {
    j.erase("outputs");
    j.erase("sweep_outputs");
  }
  return j;
}

/// The final states of two runs are identical bit for bit (the pipeline record up to paths).
inline void require_same_final_state(const fs::path& a, const fs::path& b) {
  require_identical_state(a, b, {"pipeline/record"});
  CHECK(record_without_paths(a) == record_without_paths(b));
}

/// Runs the scene uninterrupted.
inline Reference reference_run(const fs::path& scene, const fs::path& dir, const fs::path& scratch) {
  Reference ref;
  ref.dir = dir;
  const Outcome r = run_sparkdem({"run", scene.string(), "-o", dir.string(), "--quiet"}, scratch / "ref_stderr.txt");
  REQUIRE(r.exit_code == 0);
  ref.seconds = r.seconds;
  const auto runs = parse_log(dir / "run.log");
  REQUIRE(runs.size() == 1);
  REQUIRE(runs[0].completed);
  ref.log = runs[0];
  // (stage, step) names a state and one frame (a stage's closing frame is not written again
  // when its last step was a frame_every step).
  for (const ReportedFrame& f : runs[0].frames) ref.frames.emplace(FrameKey{f.stage, f.step}, f.file);
  ref.checkpoint_steps.insert(runs[0].checkpoints.begin(), runs[0].checkpoints.end());
  return ref;
}

/// What a series of kill trials exercised.
struct Counters {
  int trials = 0, killed = 0, completed = 0, killed_before_checkpoint = 0, restarted = 0, with_tmp = 0;
  std::size_t frames_checked = 0;
  std::string text() const {
    return std::to_string(killed) + " killed (" + std::to_string(killed_before_checkpoint) + " before any checkpoint, " +
           std::to_string(with_tmp) + " with a half-written .tmp file left), " + std::to_string(completed) + " finished first, " +
           std::to_string(restarted) + " restarted; " + std::to_string(frames_checked) + " reported frames checked";
  }
};

/// `trials` runs of `scene` killed at stratified random moments over the reference run's
/// duration (trial k at the fraction from + (0.95 - from) (k + u) / trials of it, u uniform in
/// [0, 1)), each checked (frames, index files,
/// checkpoint) and, when a checkpoint is left, restarted (in place on even trials, into a new
/// directory on odd ones) and compared with the reference final state.
inline Counters kill_trials(const fs::path& scene, const Reference& ref, const fs::path& scratch, int trials, std::uint32_t seed,
                            double kill_from = 0.0) {
  Counters c;
  c.trials = trials;
  // Kill moments are spread over the run's duration, taken as the shortest seen so far (the
  // reference run, or a trial that finished before its kill).
  double run_time = ref.seconds;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < trials; ++trial) {
    const fs::path dir = scratch / ("trial" + std::to_string(trial));
    const fs::path out = dir / "out";
    fs::create_directories(dir);
    const double fraction = kill_from + (0.95 - kill_from) * (trial + u(rng)) / trials;
    const auto delay = std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::duration<double>(run_time * fraction));
    const Outcome o = run_and_kill({"run", scene.string(), "-o", out.string(), "--quiet"}, dir / "stderr.txt", delay);
    INFO("trial " << trial << ": killed after " << delay.count() << " us, " << (o.killed ? "killed" : "exited"));
    if (o.killed)
      ++c.killed;
    else {
      REQUIRE(o.exit_code == 0);
      ++c.completed;
      run_time = std::min(run_time, o.seconds);
    }
    if (!fs::exists(out / "run.log")) continue;  // killed before the log was created: nothing to check
    if (has_tmp_file(out)) ++c.with_tmp;

    // (a) Every reported frame is complete and right. (A run killed right after creating its log
    // has not reported anything, not even its start.)
    const auto runs = parse_log(out / "run.log");
    REQUIRE(runs.size() <= 1);
    const RunReport killed_run = runs.empty() ? RunReport{} : runs[0];
    c.frames_checked += check_reported_frames(out, killed_run, ref);
    check_index_files(out, ref.dir);
    if (fs::exists(out / "final_state.h5")) CHECK_NOTHROW(sparkdem::io::read_verified_checkpoint(out / "final_state.h5"));

    // (b) The last checkpoint verifies and continues the run to the reference's final state.
    const fs::path ckpt = out / "checkpoint.h5";
    if (!fs::exists(ckpt)) {
      CHECK(killed_run.checkpoints.empty());  // nothing reported that is not there
      if (o.killed) ++c.killed_before_checkpoint;
      continue;
    }
    REQUIRE_NOTHROW(sparkdem::io::read_verified_checkpoint(ckpt));
    const std::int64_t step = checkpoint_step(ckpt);
    INFO("checkpoint at step " << step);
    CHECK(ref.checkpoint_steps.count(step) == 1);
    // A kill can fall between the rename and the log line: the file may be newer than the log says.
    if (!killed_run.checkpoints.empty()) CHECK(step >= killed_run.checkpoints.back());
    if (!o.killed) continue;
    const fs::path again = trial % 2 == 0 ? out : dir / "restart";
    const Outcome rr = run_sparkdem({"run", scene.string(), "--restart", ckpt.string(), "-o", again.string(), "--quiet"},
                                    dir / "restart_stderr.txt");
    REQUIRE(rr.exit_code == 0);
    ++c.restarted;
    require_same_final_state(ref.dir / "final_state.h5", again / "final_state.h5");
    const auto again_runs = parse_log(again / "run.log");
    REQUIRE(again_runs.size() == (trial % 2 == 0 ? runs.size() + 1 : 1u));
    CHECK(again_runs.back().completed);
    // A run resumed in place from a checkpoint at the run's last step writes no frame: that step's
    // frame was written before the checkpoint and is kept (OutputObserver::resumed_at).
    const bool resumed_at_last_step = again == out && !ref.log.frames.empty() && step == ref.log.frames.back().step;
    if (!resumed_at_last_step) CHECK_FALSE(again_runs.back().frames.empty());
    c.frames_checked += check_reported_frames(again, again_runs.back(), ref);
    // In place (the killed run's folder) the index lists every frame of the run, those before the
    // checkpoint kept; in another folder, the frames the restarted run wrote.
    CHECK(sparkdem::io::H5File::open_read(again / "results.h5").children("/frames").size() ==
          (again == out ? ref.frames.size() : again_runs.back().frames.size()));
    const std::vector<std::string> left = tmp_files(again);
    std::string names;
    for (const auto& f : left) names += f + " ";
    INFO("half-written files left after the restart into " << again.string() << ": " << names);
    CHECK(left.empty());
    fs::remove_all(dir);  // keep the scratch space small
  }
  return c;
}

}  // namespace sparkdem::test::crash
