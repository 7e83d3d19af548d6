#include "io/scenario/resume.hpp"

#include <algorithm>
#include <fstream>
#include <optional>
#include <tuple>

#include "engine/core/error.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "io/restart/state_file.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

/// One verified candidate: where it lies in the scenario and what the folder held then.
struct ResumeCandidate {
  fs::path file;
  std::int64_t stage = 0;
  bool in_stage = false;
  std::int64_t sweep_rows = 0;   ///< inside a sweep: items finished
  std::int64_t sweep_item = -1;  ///< inside a sweep: the item it lies in (-1: none)
  Step step = 0;
  json outputs;  ///< the folder's outputs it records (null: none)

  /// Further along the scenario is larger (see the header comment).
  auto key() const { return std::make_tuple(stage, in_stage ? 0 : 1, sweep_rows, sweep_item, step); }
};

/// The candidate files of `outdir`, in the order that wins a tie.
std::vector<fs::path> resume_candidate_files(const fs::path& outdir) {
  std::vector<fs::path> files;
  for (const char* name : {"checkpoint.h5", "checkpoint.previous.h5", "final_state.h5", "checkpoint_before_failure.h5"})
    if (fs::exists(outdir / name)) files.push_back(outdir / name);
  std::vector<fs::path> snaps;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(outdir / "snapshots", ec))
    if (e.path().extension() == ".h5") snaps.push_back(e.path());
  std::sort(snaps.begin(), snaps.end());
  files.insert(files.end(), snaps.begin(), snaps.end());
  return files;
}

/// `file` verified and read as --restart reads it; throws SetupError when it is not valid.
ResumeCandidate read_resume_candidate(const fs::path& file, const Scenario& sc) {
  ResumeCandidate c;
  c.file = file;
  Hdf5Archive ar = Hdf5Archive::for_reading(file);
  State s;
  const auto [stage, in_stage] = read_state(ar, s);
  if (stage < 0 || stage >= static_cast<std::int64_t>(sc.stages.size()))
    throw SetupError("'" + file.string() + "' is at stage " + std::to_string(stage) + ", but the scenario has " +
                     std::to_string(sc.stages.size()) + " stages");
  c.stage = stage;
  c.in_stage = in_stage;
  c.step = s.step;
  if (ar.has("pipeline/record")) {
    std::string r;
    ar.visit("pipeline/record", r);
    const json j = json::parse(r, nullptr, false);
    if (j.is_object()) {
      const json sweep = j.value("sweep", json());
      if (in_stage && sweep.is_object()) {
        c.sweep_rows = static_cast<std::int64_t>(sweep.value("rows", json::array()).size());
        if (sweep.contains("item") && sweep["item"].is_number()) c.sweep_item = sweep["item"].get<std::int64_t>();
      }
      if (j.contains("sweep_outputs") && !j["sweep_outputs"].is_null())
        c.outputs = j["sweep_outputs"];
      else
        c.outputs = j.value("outputs", json());
    }
  }
  return c;
}

std::string resume_stage_text(const Scenario& sc, std::int64_t k) {
  return "stage '" + sc.stages[static_cast<std::size_t>(k)].cfg.name + "' (" + std::to_string(k + 1) + " of " +
         std::to_string(sc.stages.size()) + ")";
}

/// Which point `c` is and what a resume from it redoes.
std::string resume_text(const Scenario& sc, const ResumeCandidate& c, const fs::path& outdir) {
  std::string where;
  if (!c.in_stage) {
    where = "the end of " + resume_stage_text(sc, c.stage) + ", step " + std::to_string(c.step);
  } else if (sc.stages[static_cast<std::size_t>(c.stage)].sweep) {
    where = "inside sweep " + resume_stage_text(sc, c.stage) + " with " + std::to_string(c.sweep_rows) + " item(s) finished" +
            (c.sweep_item >= 0 ? ", in item " + std::to_string(c.sweep_item) + " at step " + std::to_string(c.step) : std::string());
  } else {
    where = "step " + std::to_string(c.step) + " of " + resume_stage_text(sc, c.stage);
  }
  std::string text = "resuming from " + c.file.lexically_relative(outdir).string() + ": " + where + ". ";
  if (c.outputs.is_object())
    text += "Kept: " + std::to_string(c.outputs.value("frames", 0)) + " frame(s), " + std::to_string(c.outputs.value("rows", 0)) +
            " time-series row(s), " + std::to_string(c.outputs.value("stages", json::array()).size()) + " completed stage(s). ";
  else
    text += "It records no outputs of the folder (an older sparkdem wrote it): the results are started afresh. ";
  const std::int64_t next = c.in_stage ? c.stage : c.stage + 1;
  if (next >= static_cast<std::int64_t>(sc.stages.size())) return text + "Redone: nothing but the closing outputs (it was the last stage).";
  text += "Redone: whatever the killed run did after that point";
  if (c.in_stage) text += sc.stages[static_cast<std::size_t>(c.stage)].sweep ? " (the unfinished items)" : " in that stage";
  text += ", then " + (next + 1 < static_cast<std::int64_t>(sc.stages.size()) || !c.in_stage ? std::string("every later stage") : std::string("the run's end"));
  if (!c.in_stage) text += " from " + resume_stage_text(sc, next);
  return text + ".";
}

}  // namespace

ResumeChoice find_resume_point(const Scenario& sc, const fs::path& outdir) {
  std::error_code ec;
  if (!fs::is_directory(outdir, ec)) throw NothingToResume("nothing to resume: the output directory '" + outdir.string() + "' does not exist");
  if (fs::exists(outdir / "resolved.json")) {
    std::ifstream in(outdir / "resolved.json");
    const json there = json::parse(in, nullptr, false);
    const json here = json::parse(sc.resolved.dump());  // as written (an infinite value reads back as null)
    if (there != here) {
      const json patch = json::diff(there, here);
      const std::string first = patch.empty() ? std::string("?") : patch[0].value("path", std::string("?"));
      throw NothingToResume("cannot resume in '" + outdir.string() +
                            "': its resolved.json is not this scenario as resolved now (a different scenario file, or one "
                            "changed since the run started; first difference at " + first +
                            "); run into a new directory, or restart explicitly with --restart FILE");
    }
  }
  ResumeChoice choice;
  if (fs::exists(outdir / "summary.json")) {
    std::ifstream in(outdir / "summary.json");
    const json summary = json::parse(in, nullptr, false);
    if (summary.is_object() && summary.value("status", std::string()) == "completed") {
      choice.finished = true;
      choice.description = "the run in '" + outdir.string() + "' has completed (summary.json): nothing to resume";
      return choice;
    }
  }
  std::optional<ResumeCandidate> best;
  for (const fs::path& f : resume_candidate_files(outdir)) {
    try {
      ResumeCandidate c = read_resume_candidate(f, sc);
      if (!best || c.key() > best->key()) best = std::move(c);
    } catch (const std::exception& e) {
      choice.passed_over.push_back(f.lexically_relative(outdir).string() + ": " + e.what());
    }
  }
  if (!best) {
    std::string text = "nothing to resume in '" + outdir.string() +
                       "': no valid restart point (checkpoint.h5, checkpoint.previous.h5, final_state.h5, "
                       "checkpoint_before_failure.h5, snapshots/*.h5)";
    for (const auto& p : choice.passed_over) text += "; passed over " + p;
    throw NothingToResume(text + "; run without --resume to start afresh");
  }
  choice.file = best->file;
  choice.description = resume_text(sc, *best, outdir);
  return choice;
}

}  // namespace sparkdem::io
