/// sparkdem command line: run | check | schema | calibrate | --version.
/// The only place that prints errors and chooses exit codes:
///   0 success, 1 internal error (a bug), 2 invalid scenario or input, 3 physics failure
///   (blow-up, unmet required stop), 4 set-up failure (including a missing, truncated or corrupt
///   checkpoint or snapshot), 5 a banded check failed (`run` completed with every output
///   written, but a top-level check with tolerance > 0 is outside its band or could not be
///   evaluated; `run --report-only` exits 0 instead), 130 interrupted (checkpoint written).
#include <omp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cctype>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/core/interrupt.hpp"
#include "engine/graph/hypre_amg.hpp"
#include "engine/state/particle_set.hpp"
#include "io/mpi/ranks.hpp"
#include "io/version/build_info.hpp"
#include "io/scenario/calibrate_beams.hpp"
#include "io/scenario/json_binder.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/resume.hpp"
#include "io/scenario/sweep.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace {

void on_signal(int) { sparkdem::interrupt_flag().store(true); }

/// Prints the banded checks of a completed run that failed (summary["checks_failed"]); returns
/// the exit code: 0 when none failed or `report_only`, else 5.
int checks_exit_code(const sparkdem::io::json& summary, bool report_only) {
  const auto failed = summary.value("checks_failed", sparkdem::io::json::array());
  if (failed.empty()) return 0;
  for (const auto& name : failed) {
    const std::string n = name.get<std::string>();
    std::cerr << (report_only ? "warning" : "error") << ": check '" << n
              << "' failed: " << summary["checks"][n].value("failure", std::string("outside its band")) << "\n";
  }
  std::cerr << failed.size() << " banded check(s) failed; the run completed and wrote all its outputs ("
            << (report_only ? "--report-only: exit code 0" : "exit code 5; --report-only exits 0") << ")\n";
  return report_only ? 0 : 5;
}

/// `arg` as one shell word: as it is when it holds only safe characters, else in single quotes.
std::string shell_word(const std::string& arg) {
  const bool safe = !arg.empty() && std::all_of(arg.begin(), arg.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || std::string_view("/._-+=:,@%").find(c) != std::string_view::npos;
  });
  if (safe) return arg;
  std::string out = "'";
  for (const char c : arg) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// After a failed run (not an interrupt): when a stage completed in it, where its end state is and
/// the command that continues the scenario from the stage after it (`--restart FINAL_STATE`, into
/// a new directory so that the frames and index files of this run stay).
void print_continue_hint(std::ostream& out, const sparkdem::io::RunProgress& p, std::vector<std::string> command,
                         const std::filesystem::path& outdir) {
  if (p.final_state.empty() || p.stage_number >= p.stages) return;  // nothing completed, or nothing left to run
  std::filesystem::path next = outdir;
  next += "_continued";
  command.insert(command.begin() + 3, {"-o", next.string(), "--restart", p.final_state.string()});
  std::string line;
  for (const auto& a : command) line += (line.empty() ? "" : " ") + shell_word(a);
  out << "stage '" << p.stage << "' (" << p.stage_number << " of " << p.stages << ") "
      << (p.until_unmet ? "ended at its hard stop with its required 'until' conditions unmet" : "was the last stage to complete")
      << "; its end state is " << p.final_state.string() << ". To continue the run from it with stage '" << p.next_stage << "' ("
      << p.stage_number + 1 << " of " << p.stages << ")" << (p.until_unmet ? ", accepting that state," : " once the cause is fixed")
      << ":\n  " << line << "\n(a new output directory leaves this run's folder " << outdir.string()
      << " as it is; `--restart " << p.final_state.string() << "` into it instead continues it in place, keeping its frames, rows and stages";
  if (sparkdem::io::ranks::size() > 1)
    out << "; this run had " << sparkdem::io::ranks::size() << " MPI ranks: start it under the same launcher, e.g. mpirun -np "
        << sparkdem::io::ranks::size();
  out << ")\n";
}

constexpr const char* kRunFooter =
    "Exit codes: 0 success; 1 internal error; 2 invalid scenario; 3 physics failure; 4 set-up failure "
    "(checkpoint, snapshot, ...); 5 the run completed (all outputs written) but a top-level check with a "
    "tolerance band (\"tolerance\" > 0) is outside it or could not be evaluated (named on stderr, in run.log "
    "and in summary.json \"checks_failed\"; --report-only: exit 0); 130 interrupted (checkpoint written).";

}  // namespace

/// Errors go to stderr on rank 0 only (every rank of an MPI run meets the same input error).
std::ostream& err() {
  static std::ostream null(nullptr);
  return sparkdem::io::ranks::rank() == 0 ? std::cerr : null;
}

/// OpenMP threads of each rank: `requested`, or with 0 on several ranks the cores shared out.
int threads_per_rank(int requested) {
  if (requested > 0 || sparkdem::io::ranks::size() == 1) return requested;
  return std::max(1, omp_get_num_procs() / sparkdem::io::ranks::size());
}

/// The command line's options (one set for every subcommand).
struct CliArgs {
  std::string scene, outdir = "out", restart;
  int threads = 0;
  bool quiet = false, report_only = false, resume = false;
};

/// `sparkdem calibrate`: fit cohesive-beam parameters on the tension test of calibration file `file`.
int calibrate_command(const sparkdem::io::json& j, const std::filesystem::path& file, const CliArgs& a, const sparkdem::Registry& reg) {
  using namespace sparkdem;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  const io::CalibrationSpec spec = io::parse_calibration(j, file.has_parent_path() ? file.parent_path() : std::filesystem::path("."));
  io::CalibrationOptions copt;
  copt.outdir = io::resolve_output_directory(a.outdir);
  copt.threads = a.threads;
  if (!a.quiet)
    copt.on_iteration = [](const io::json& it) {
      err() << "iteration " << it["iteration"] << ": radius_ratio " << it["radius_ratio"] << ", E_mu " << it["young_modulus_Pa"]
            << " Pa -> E_M " << it["measured_young_modulus_Pa"] << " Pa, nu_M " << it["measured_poisson_ratio"] << " (errors "
            << it["error_young_modulus"] << ", " << it["error_poisson_ratio"] << "), " << it["wall_time_s"] << " s\n";
    };
  const io::json rep = io::calibrate_beams(spec, reg, copt);
  if (!a.quiet)
    err() << "calibrated: " << rep["result"]["params"].dump() << " written to " << spec.write.string() << "; report "
          << (std::filesystem::path(a.outdir) / "calibration.json").string() << "\n";
  return 0;
}

/// `sparkdem run` of a loaded scenario: rank 0 runs it (the other ranks serve its sweep items);
/// `progress` and `physical_outdir` say how far it got, for the advice after a failure.
int run_scene(sparkdem::io::Scenario& sc, CliArgs a, sparkdem::io::RunProgress& progress, std::filesystem::path& physical_outdir,
              bool& serving) {
  using namespace sparkdem;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  a.threads = threads_per_rank(a.threads);
  if (io::ranks::rank() != 0) {
    if (a.threads > 0) omp_set_num_threads(a.threads);
    return io::serve_sweep_items(sc);
  }
  serving = io::ranks::size() > 1;
  set_amg_spread_ranks(io::ranks::size());  // large network solves outside sweeps use every rank
  // Only an existing directory is searched for --resume (resolve_output_directory creates one).
  if (a.resume && !std::filesystem::is_directory(a.outdir))
    throw io::NothingToResume("nothing to resume: the output directory '" + a.outdir + "' does not exist");
  io::RunOptions opt;
  // Resolved once: every file goes to the physical path ("LINK/../out" as the OS takes it);
  // messages show the path as given, and the physical one where it differs.
  opt.outdir = io::resolve_output_directory(a.outdir);
  opt.quiet = a.quiet;
  opt.threads = a.threads;
  opt.progress = &progress;
  if (!a.restart.empty()) opt.restart = a.restart;
  if (a.resume) {
    const io::ResumeChoice c = io::find_resume_point(sc, opt.outdir);
    if (!a.quiet)
      for (const auto& p : c.passed_over) err() << "--resume: passed over " << p << "\n";
    if (c.finished) {
      err() << c.description << "\n";
      return 0;
    }
    err() << c.description << "\n";
    opt.restart = c.file;
  }
  physical_outdir = opt.outdir;
  const io::json summary = io::run_scenario(sc, opt);
  if (!a.quiet)
    err() << "done: " << summary["steps"] << " steps, " << summary["wall_time_s"] << " s wall, " << summary["particle_steps_per_s"]
          << " particle-steps/s; outputs in " << a.outdir
          << ((std::filesystem::absolute(a.outdir) / "").lexically_normal() != (opt.outdir / "").lexically_normal()
                  ? " (" + opt.outdir.string() + ")"
                  : std::string())
          << "\n";
  return checks_exit_code(summary, a.report_only);
}

/// The command line's work; `serving` is set on rank 0 of an MPI run once the other ranks wait
/// for sweep items (main then sends them the stop signal with the exit code).
int run_command(int argc, char** argv, bool& serving) {
  using namespace sparkdem;
  CLI::App app{"sparkdem: coupled thermo-electro-mechanical DEM"};
  app.set_version_flag("--version", std::string("sparkdem ") + SPARKDEM_VERSION + ", " + io::build_info_text());
  app.require_subcommand(1);
  CliArgs a;
  auto* run = app.add_subcommand("run", "run a scenario");
  run->footer(kRunFooter);
  run->add_option("scene", a.scene, "scenario JSON file")->required();
  run->add_option("-o,--output", a.outdir, "output directory");
  run->add_option("--threads", a.threads, "OpenMP threads (0 = default)");
  auto* restart = run->add_option("--restart", a.restart,
                                  "continue from this checkpoint (one in OUTDIR or OUTDIR/snapshots continues the folder in place)");
  run->add_flag("--resume", a.resume,
                "continue the run in OUTDIR in place from its newest valid restart point (checkpoint, snapshot, end of a stage); "
                "exit 2 when there is none, 0 when the run has completed")
      ->excludes(restart);
  run->add_flag("--quiet", a.quiet, "no progress output");
  run->add_flag("--report-only", a.report_only,
                "checks with a tolerance band only report (summary.json, run.log, stderr): exit 0 when one fails");
  auto* check = app.add_subcommand("check", "validate a scenario and print it resolved");
  check->add_option("scene", a.scene, "scenario JSON file")->required();
  auto* schema = app.add_subcommand("schema", "print every stage, law, module and generator with its parameters");
  auto* calibrate = app.add_subcommand("calibrate",
                                       "calibrate cohesive_beam parameters on a tension test (see io/scenario/calibrate_beams.hpp)");
  calibrate->add_option("calibration", a.scene, "calibration JSON file")->required();
  calibrate->add_option("-o,--output", a.outdir, "output directory (one run per iteration, calibration.json)");
  calibrate->add_option("--threads", a.threads, "OpenMP threads (0 = default)");
  calibrate->add_flag("--quiet", a.quiet, "no progress output");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int rc = io::ranks::rank() == 0 ? app.exit(e) : app.exit(e, err(), err());
    return rc == 0 ? 0 : 2;
  }
  // On several ranks only `run` has work for the ranks other than 0.
  if (io::ranks::rank() != 0 && !run->parsed()) return 0;

  Registry reg;
  physics::register_all(reg);
  // A failed run that completed a stage says how to continue from it (print_continue_hint).
  io::RunProgress progress;
  std::filesystem::path physical_outdir;
  std::vector<std::string> again{argv[0], "run", a.scene};  // -o and --restart are inserted after these
  if (a.threads != 0) again.insert(again.end(), {"--threads", std::to_string(a.threads)});
  if (a.quiet) again.push_back("--quiet");
  if (a.report_only) again.push_back("--report-only");
  auto hint = [&] {
    if (run->parsed()) print_continue_hint(err(), progress, again, physical_outdir);
  };
  try {
    if (schema->parsed()) {
      std::cout << io::schema_json(reg).dump(2) << "\n";
      return 0;
    }
    const std::filesystem::path file(a.scene);
    const io::json j = io::read_json_file(file);
    if (calibrate->parsed()) return calibrate_command(j, file, a, reg);
    io::Scenario sc = io::load_scenario(j, reg, file.has_parent_path() ? file.parent_path() : std::filesystem::path("."));
    if (check->parsed()) {
      std::cout << io::dry_run(sc).dump(2) << "\n";
      return 0;
    }
    return run_scene(sc, a, progress, physical_outdir, serving);
  } catch (const ConfigError& e) {
    err() << "error: " << e.what() << "\n";
    hint();
    return 2;
  } catch (const io::NothingToResume& e) {
    err() << "error: " << e.what() << "\n";
    return 2;
  } catch (const Interrupted& e) {
    err() << "\n" << e.what() << "\n";
    return 130;
  } catch (const PhysicsError& e) {
    err() << "error: " << e.what() << "\n";
    hint();
    return 3;
  } catch (const SetupError& e) {
    err() << "error: " << e.what() << "\n";
    hint();
    return 4;
  } catch (const std::exception& e) {
    err() << "internal error: " << e.what() << "\n";
    hint();
    return 1;
  }
}

int main(int argc, char** argv) {
  try {
    sparkdem::io::ranks::init(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 4;
  }
  bool serving = false;
  const int rc = run_command(argc, argv, serving);
  if (serving) sparkdem::io::stop_sweep_servers(rc);
  sparkdem::io::ranks::finalize();
  return rc;
}
