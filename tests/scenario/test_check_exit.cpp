/// Top-level "checks" with a tolerance band decide the exit code of `sparkdem run` (io/cli/main.cpp):
/// the run completes and writes every output, then a banded check outside its band, or one that
/// could not be evaluated, gives exit code 5, named with its figures on stderr, in run.log and in
/// summary.json "checks_failed"; `--report-only` exits 0; tolerance 0 only reports. The scene:
/// spheres far apart falling freely from rest for 100 steps of 1e-4 s, whose speed is g t
/// (velocity Verlet is exact for a constant acceleration: 0.0981 m/s to rounding, ~1e-15).
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_check_exit {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

constexpr double kSpeed = 9.81 * 100 * 1e-4;  // g t [m/s]

/// Spheres on a 2 x 2 x 2 lattice, 5 mm apart (2 mm diameter: no contact), no walls; `checks`.
json fall_scene(const std::vector<json>& checks) {
  return {
      {"name", "free_fall_checks"},
      {"seed", 1},
      {"materials", {{{"name", "glass"}, {"density", 2500}}}},
      {"contact",
       {{"law", "hertz_mindlin"}, {"params", {{"youngs_modulus", 1e6}, {"poisson_ratio", 0.3}, {"restitution", 0.5}, {"friction", 0.3}}}}},
      {"stages",
       {{{"name", "create"},
         {"type", "lattice"},
         {"generator", {{"lo", {0.0, 0.0, 0.0}}, {"hi", {0.006, 0.006, 0.006}}, {"spacing", 0.005}, {"diameter", 0.002}}}},
        {{"name", "fall"},
         {"type", "dynamics"},
         {"dt", 1e-4},
         {"modules", {{"gravity", {{"acceleration", {0, 0, -9.81}}}}}},
         {"stop", {{"steps", 100}}},
         {"output", {{"timeseries_every", 50}}}}}},
      {"checks", json(checks)}};
}

json speed_check(double reference, double tolerance, const std::string& column = "max_speed") {
  return {{"name", "fall_speed"},   {"stage", "fall"},        {"column", column},
          {"reference", reference}, {"tolerance", tolerance}, {"source", "g t, exact for velocity Verlet"}};
}

struct Cli {
  int code = -1;
  std::string out, err;
};

std::string read_text(const fs::path& f) {
  std::ifstream in(f);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Runs the sparkdem executable with `args` (shell words) in `dir`.
Cli cli(const std::string& args, const fs::path& dir) {
  const std::string cmd = "OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=1 '" + std::string(SPARKDEM_BINARY) + "' " + args + " > '" +
                          (dir / "stdout.txt").string() + "' 2> '" + (dir / "stderr.txt").string() + "'";
  const int rc = std::system(cmd.c_str());
  Cli r;
  if (rc != -1 && WIFEXITED(rc)) r.code = WEXITSTATUS(rc);
  r.out = read_text(dir / "stdout.txt");
  r.err = read_text(dir / "stderr.txt");
  UNSCOPED_INFO("sparkdem " << args << " -> " << r.code << "; stderr: " << r.err);
  return r;
}

/// `sparkdem run` of `scene` into dir/out (with `flags`).
Cli run(const json& scene, const fs::path& dir, const std::string& flags = "") {
  const fs::path file = test::write_scene(dir, "scene.json", scene);
  return cli("run '" + file.string() + "' -o '" + (dir / "out").string() + "' --quiet " + flags, dir);
}

json summary_of(const fs::path& dir) { return json::parse(read_text(dir / "out" / "summary.json")); }

bool contains(const std::string& text, const std::string& what) { return text.find(what) != std::string::npos; }

/// Every output of a completed run is there.
void require_complete_outputs(const fs::path& dir) {
  for (const char* f : {"summary.json", "final_state.h5", "results.h5", "results.xdmf", "timeseries.csv", "run.log"})
    CHECK(fs::exists(dir / "out" / f));
  CHECK(contains(read_text(dir / "out" / "run.log"), "] run completed: 100 steps"));
}

}  // namespace

TEST_CASE("a banded check inside its band exits 0; tolerance 0 only reports", "[check][scenario]") {
  test::ScratchDir tmp("sparkdem_check_pass");
  json report = speed_check(2.0 * kSpeed, 0.0);
  report["name"] = "report_only_figure";
  const Cli r = run(fall_scene({speed_check(kSpeed, 1e-9), report}), tmp.path);
  CHECK(r.code == 0);
  require_complete_outputs(tmp.path);
  const json s = summary_of(tmp.path);
  CHECK(s["status"] == "completed");
  CHECK(s["checks_failed"] == json::array());
  CHECK(s["checks"]["fall_speed"]["within_tolerance"] == true);
  CHECK(std::abs(s["checks"]["fall_speed"]["value"].get<double>() / kSpeed - 1.0) <= 1e-12);
  // 50 % off, but with no band: reported (error -0.5), not failed.
  CHECK(std::abs(s["checks"]["report_only_figure"]["error_rel"].get<double>() + 0.5) <= 1e-12);
  CHECK_FALSE(s["checks"]["report_only_figure"].contains("within_tolerance"));
  CHECK_FALSE(contains(r.err, "failed"));
}

TEST_CASE("a banded check outside its band: outputs complete, exit 5, the check named with its miss; --report-only exits 0",
          "[check][scenario]") {
  // Reference 0.1 m/s against 0.0981: relative error -1.9 %, band 1 %: misses by 0.9 % of the
  // reference (|value - reference| = 0.0019 m/s, the band allows 0.001).
  const json scene = fall_scene({speed_check(0.1, 0.01)});
  for (const bool report_only : {false, true}) {
    INFO("--report-only: " << report_only);
    test::ScratchDir tmp("sparkdem_check_miss");
    const Cli r = run(scene, tmp.path, report_only ? "--report-only" : "");
    CHECK(r.code == (report_only ? 0 : 5));
    require_complete_outputs(tmp.path);
    const json s = summary_of(tmp.path);
    CHECK(s["status"] == "completed");  // the run itself completed
    CHECK(s["checks_failed"] == json::array({"fall_speed"}));
    const json& c = s["checks"]["fall_speed"];
    CHECK(c["within_tolerance"] == false);
    CHECK(std::abs(c["error_rel"].get<double>() - (kSpeed / 0.1 - 1.0)) <= 1e-12);
    const std::string expected =
        "check 'fall_speed' failed: value 0.0981 against reference 0.1: relative error -1.9 %, "
        "outside the band +-1 % by 0.9 % of the reference (|value - reference| = 0.0019, "
        "the band allows 0.001)";
    CHECK(contains(r.err, expected));
    CHECK(contains(r.err, report_only ? "warning: " : "error: "));
    CHECK(contains(read_text(tmp.path / "out" / "run.log"), expected));
    CHECK(c["failure"].get<std::string>() == expected.substr(std::string("check 'fall_speed' failed: ").size()));
  }
}

TEST_CASE("a banded check that cannot be evaluated fails (exit 5); one on a stage without final values is refused at load",
          "[check][scenario]") {
  test::ScratchDir tmp("sparkdem_check_missing");
  const Cli r = run(fall_scene({speed_check(kSpeed, 0.05, "no_such_column")}), tmp.path);
  CHECK(r.code == 5);
  require_complete_outputs(tmp.path);
  const json s = summary_of(tmp.path);
  CHECK(s["checks_failed"] == json::array({"fall_speed"}));
  CHECK(contains(r.err, "check 'fall_speed' failed: not evaluated: the stage has no final value of this column"));

  // A generator stage and a sweep stage have no final values: a banded check on them is refused
  // (exit 2, the check's path named); with tolerance 0 it is accepted (report only).
  json lattice = speed_check(kSpeed, 0.05);
  lattice["stage"] = "create";
  const Cli refused = run(fall_scene({lattice}), tmp.path);
  CHECK(refused.code == 2);
  CHECK(contains(refused.err, "/checks/0/stage"));
  CHECK(contains(refused.err, "a generator stage without dynamics"));
  json sweep = test::load_data("sweep_fall.json");
  sweep["checks"] = {{{"name", "x"}, {"stage", "more"}, {"column", "max_speed"}, {"reference", 1.0}, {"tolerance", 0.1}}};
  try {
    (void)io::load_scenario(sweep, test::registry(), tmp.path);
    FAIL("a banded check on a sweep stage was accepted");
  } catch (const ConfigError& e) {
    CHECK(contains(e.what(), "/checks/0/stage"));
    CHECK(contains(e.what(), "a sweep stage"));
  }
  sweep["checks"][0]["tolerance"] = 0.0;
  CHECK_NOTHROW(io::load_scenario(sweep, test::registry(), tmp.path));
}

TEST_CASE("sparkdem run --help documents --report-only and exit code 5", "[check][scenario]") {
  test::ScratchDir tmp("sparkdem_check_help");
  const Cli r = cli("run --help", tmp.path);
  CHECK(r.code == 0);
  CHECK(contains(r.out, "--report-only"));
  CHECK(contains(r.out, "5 the run completed"));
}

}  // namespace test_check_exit
