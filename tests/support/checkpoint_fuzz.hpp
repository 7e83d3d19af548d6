#pragma once
/// Shared pieces of the restart-reader fuzzers (tests/fuzz/fuzz_driver.cpp at scale,
/// tests/scenario/test_fuzz_checkpoint.cpp in CI): the outcome classes of a case run in a forked
/// child, genuine seed checkpoints, and one mutated restart.
///
/// A seed is a checkpoint taken 40 steps before the end of a scene's last stage (so a restart has
/// little left to run). A case mutates it (test::CheckpointMutator: 3 in 4 structure-aware, 1 in 4
/// byte-level), re-seals it with a valid checksum header and gives it to io::run_scenario with
/// RunOptions::restart, the path of `sparkdem run --restart`: the checkpoint is read, the state
/// and module states restored, the run continued to its end and every output written.
/// Expected outcomes: completed, SetupError (CLI exit code 4), PhysicsError (exit code 3) or
/// ConfigError. Anything else is a bug: another exception (std::bad_alloc, std::out_of_range,
/// ...), a crash (signal) or a hang (time limit).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <typeinfo>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/checkpoint_mutator.hpp"
#include "support/child_process.hpp"

namespace sparkdem::test::fuzz {

namespace fs = std::filesystem;
using nlohmann::json;

// Exit codes of a child case.
constexpr int kOk = 0, kSetup = 10, kPhysics = 11, kConfig = 12, kInterrupted = 13, kOther = 20;

inline std::string class_name(const ChildResult& r) {
  switch (r.kind) {
    case ChildResult::Kind::Crashed:
      return "crash (signal " + std::to_string(r.signal) + ")";
    case ChildResult::Kind::TimedOut:
      return "hang (time limit)";
    case ChildResult::Kind::Exited:
      break;
  }
  switch (r.exit_code) {
    case kOk:
      return "ok";
    case kSetup:
      return "SetupError";
    case kPhysics:
      return "PhysicsError";
    case kConfig:
      return "ConfigError";
    case kInterrupted:
      return "Interrupted";
    case kOther:
      return "untyped exception";
    default:
      return "exit " + std::to_string(r.exit_code);
  }
}

inline bool is_bug(const ChildResult& r) {
  return r.kind != ChildResult::Kind::Exited ||
         !(r.exit_code == kOk || r.exit_code == kSetup || r.exit_code == kPhysics || r.exit_code == kConfig);
}

/// Runs `f` (in a child) and maps its exception to an exit code (the message goes to the pipe).
template <class F>
int classify(F&& f) {
  try {
    f();
    return kOk;
  } catch (const SetupError& e) {
    child_message(e.what());
    return kSetup;
  } catch (const PhysicsError& e) {
    child_message(e.what());
    return kPhysics;
  } catch (const ConfigError& e) {
    child_message(e.what());
    return kConfig;
  } catch (const Interrupted& e) {
    child_message(e.what());
    return kInterrupted;
  } catch (const std::exception& e) {
    child_message(std::string("untyped exception: ") + typeid(e).name() + ": " + e.what());
    return kOther;
  }
}

/// Address-space limit of a case's child process: a huge allocation fails instead of swapping.
constexpr std::size_t kAddressSpace = std::size_t{3} << 30;

/// A genuine checkpoint of a scene, with the loaded scenario to restart it.
struct CkptSeed {
  std::string name;
  json scene;
  io::Scenario sc;
  fs::path checkpoint;
  CkptModel model;
  std::vector<unsigned char> bytes;
  std::int64_t step = 0;
};

/// Runs a scene to its end (or from `restart`) in a child process, so this process never starts
/// OpenMP workers (it forks).
inline void run_scene_in_child(const Registry& reg, const json& scene, const fs::path& base, const fs::path& out, unsigned time_limit,
                               const std::optional<fs::path>& restart = {}) {
  const ChildResult r = run_in_child(
      [&] {
        return classify([&] {
          io::Scenario sc = io::load_scenario(scene, reg, base);
          io::RunOptions opt;
          opt.outdir = out;
          opt.quiet = true;
          opt.threads = 1;
          opt.restart = restart;
          io::run_scenario(sc, opt);
        });
      },
      time_limit, 0);
  if (is_bug(r) || r.exit_code != kOk)
    throw std::runtime_error("run into " + out.string() + " failed: " + class_name(r) + ": " + r.message);
}

/// A genuine checkpoint of tests/scenario/data/<name> 40 steps before the end of its last stage;
/// the unmutated checkpoint is restarted once (it must complete).
inline CkptSeed make_checkpoint_seed(const Registry& reg, const fs::path& data_dir, const std::string& name, const fs::path& dir,
                                     unsigned time_limit) {
  CkptSeed s;
  s.name = name;
  s.scene = json::parse(std::ifstream(data_dir / name));
  run_scene_in_child(reg, s.scene, data_dir, dir / "plain", time_limit);
  const json summary = json::parse(std::ifstream(dir / "plain/summary.json"));
  // The global step at the end (summary.json's "steps" also counts the steps of sweep items).
  const std::int64_t total = read_checkpoint_model(dir / "plain/final_state.h5").at("state/step").i.at(0);
  const auto last_steps = summary["stages"].back()["steps"].get<std::int64_t>();
  if (total < 100 || last_steps < 41) throw std::runtime_error(name + ": last stage too short for a seed checkpoint");
  json split = s.scene;
  split["stages"].back()["output"]["checkpoint_every"] = total - 40;  // one checkpoint, at step total - 40
  run_scene_in_child(reg, split, data_dir, dir / "split", time_limit);
  s.checkpoint = dir / "seed_checkpoint.h5";
  fs::copy_file(dir / "split/checkpoint.h5", s.checkpoint, fs::copy_options::overwrite_existing);
  s.model = read_checkpoint_model(s.checkpoint);
  s.bytes = file_bytes(s.checkpoint);
  s.step = s.model.at("state/step").i.at(0);
  s.sc = io::load_scenario(s.scene, reg, data_dir);
  run_scene_in_child(reg, s.scene, data_dir, dir / "restart", time_limit, s.checkpoint);
  return s;
}

/// Writes case `case_seed`'s mutation of the seed to `file` (sealed); returns its recipe.
/// Throws std::runtime_error when HDF5 refuses to write the mutated model (not a case).
inline std::string write_mutated_checkpoint(const CkptSeed& s, std::uint64_t case_seed, const fs::path& file) {
  CheckpointMutator mut(case_seed);
  if (mut.pick(4) == 0) {
    std::vector<unsigned char> b = s.bytes;
    const std::string what = "bytes: " + mut.mutate_bytes(b);
    write_sealed_bytes(std::move(b), file);
    return what;
  }
  CkptModel m = s.model;
  const std::string what = "model: " + mut.mutate_model(m);
  write_checkpoint_model(m, file);
  return what;
}

/// Restarts the seed's scenario from `file` into `out`, in a child process.
inline ChildResult restart_case(CkptSeed& s, const fs::path& file, const fs::path& out, unsigned time_limit) {
  std::error_code ec;
  fs::remove_all(out, ec);
  return run_in_child(
      [&] {
        return classify([&] {
          io::RunOptions opt;
          opt.outdir = out;
          opt.quiet = true;
          opt.threads = 1;
          opt.restart = file;
          io::run_scenario(s.sc, opt);
        });
      },
      time_limit, kAddressSpace);
}

}  // namespace sparkdem::test::fuzz
