// `sparkdem calibrate` (issue 7, item 4; io/scenario/calibrate_beams.hpp): a fast calibration
// on a small bonded sample converges to its targets, writes an includable params file, and a
// bad calibration file is rejected with every problem listed.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "engine/core/error.hpp"
#include "io/scenario/calibrate_beams.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_calibrate_beams {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

namespace {
const fs::path kSmall = fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/tension_small.json";

json read(const fs::path& f) { return json::parse(std::ifstream(f)); }
}  // namespace

TEST_CASE("calibrate: a small bonded sample converges to its E, nu targets and the strength is sigma_t times the stress ratio",
          "[calibrate][scenario][beam]") {
  // 300 elements, 800 steps per run (seconds). Targets chosen away from the starting point
  // (r~ = 0.5, E_mu = 124 GPa) so that both parameters must move; tolerance 1 %.
  test::ScratchDir tmp("sparkdem_calibrate");
  const json cal = {{"scenario", kSmall.string()},
                    {"stage", "hold"},
                    {"targets", {{"young_modulus", 60e9}, {"poisson_ratio", 0.22}, {"tensile_strength", 5e6}}},
                    {"initial", {{"radius_ratio", 0.5}, {"young_modulus", 124e9}}},
                    {"tolerance", 0.01},
                    {"max_iterations", 12},
                    {"write", "out_params/beams.json"},
                    {"check_break", "pull"}};
  const fs::path file = test::write_scene(tmp.path, "cal.json", cal);
  const io::CalibrationSpec spec = io::parse_calibration(read(file), tmp.path);
  io::CalibrationOptions opt;
  opt.outdir = tmp.path / "out";
  opt.threads = 1;
  const json rep = io::calibrate_beams(spec, test::registry(), opt);
  REQUIRE(rep["converged"] == true);
  const json& last = rep["iterations"].back();
  INFO(rep.dump(1));
  // The converged run's measured values are within the tolerance of the targets.
  CHECK(std::abs(last["measured_young_modulus_Pa"].get<double>() / 60e9 - 1.0) < 0.01);
  CHECK(std::abs(last["measured_poisson_ratio"].get<double>() / 0.22 - 1.0) < 0.01);
  CHECK(rep["iterations"].size() >= 2);
  // The params file holds exactly the cohesive_beam params of the converged iteration.
  const json params = read(spec.write);
  CHECK(params.size() == 5);
  CHECK(params["radius_ratio"] == last["radius_ratio"]);
  CHECK(params["young_modulus"] == last["young_modulus_Pa"]);
  CHECK(params["failure"] == "von_mises");
  CHECK(params["poisson_ratio"] == 0.3);
  const double ratio = last["max_failure_stress_Pa"].get<double>() / last["tension_stress_Pa"].get<double>();
  CHECK(params["strength"].get<double>() == Approx(5e6 * ratio).epsilon(1e-12));
  CHECK(ratio > 1.0);  // a bond's criterion stress exceeds the mean stress
  CHECK(read(opt.outdir / "calibration.json") == rep);
  // Elastic until the first break: with the calibrated strength the first bond breaks when the
  // macroscopic stress reaches sigma_t, up to the dynamic lag of the pull and the sampling
  // (the stress is sampled at the break step): 3 %.
  REQUIRE(rep.contains("check_break"));
  CHECK(rep["check_break"]["broke"] == true);
  CHECK(rep["check_break"]["relative_to_tensile_strength"].get<double>() == Approx(1.0).margin(0.03));

  SECTION("the params file can be included at /bonds/params") {
    json scene = read(kSmall);
    scene["bonds"]["params"] = {{"$include", fs::absolute(spec.write).string()}};
    const io::Scenario sc = io::load_scenario(scene, test::registry(), tmp.path);
    const json& bp = sc.resolved["bonds"]["params"];
    for (const char* k : {"young_modulus", "poisson_ratio", "radius_ratio", "failure", "strength"}) CHECK(bp[k] == params[k]);
  }
}

TEST_CASE("calibrate: a bad calibration file is rejected with every problem at once (ConfigError, exit 2)",
          "[calibrate][scenario][config]") {
  test::ScratchDir tmp("sparkdem_calibrate_bad");
  const json bad = {{"scenario", "missing_scene.json"},
                    {"targets", {{"young_modulus", -1.0}, {"poisson_ratio", 0.7}}},
                    {"initial", {{"radius_ratio", 0.5}, {"young_modulus", "124 GPa"}}},
                    {"tolerance", 2.0},
                    {"max_iterations", 0},
                    {"write", "p.json"},
                    {"colour", "red"}};
  const std::vector<std::string> paths = {"/scenario",
                                          "/stage",
                                          "/targets/young_modulus",
                                          "/targets/poisson_ratio",
                                          "/targets/tensile_strength",
                                          "/initial/young_modulus",
                                          "/tolerance",
                                          "/max_iterations",
                                          "/colour"};
  try {
    io::parse_calibration(bad, tmp.path);
    FAIL("no ConfigError");
  } catch (const ConfigError& e) {
    INFO(e.what());
    CHECK(e.diagnostics().size() == paths.size());
    for (const auto& p : paths) {
      bool found = false;
      for (const auto& d : e.diagnostics()) found = found || d.path == p;
      CHECK(found);
    }
  }
  // The command line reports them all with exit code 2 and writes no output directory.
  const fs::path f = test::write_scene(tmp.path, "bad.json", bad);
  const fs::path err = tmp.path / "stderr.txt";
  const std::string cmd = "OMP_NUM_THREADS=1 '" + std::string(SPARKDEM_BINARY) + "' calibrate '" + f.string() + "' -o '" +
                          (tmp.path / "out").string() + "' > /dev/null 2> '" + err.string() + "'";
  const int rc = std::system(cmd.c_str());
  REQUIRE(WIFEXITED(rc));
  CHECK(WEXITSTATUS(rc) == 2);
  std::ifstream in(err);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  for (const auto& p : paths) CHECK(text.find(p + ":") != std::string::npos);
  CHECK(!fs::exists(tmp.path / "out"));

  SECTION("a scene without a failure criterion cannot be calibrated") {
    json scene = read(kSmall);
    scene["bonds"]["params"].erase("failure");
    const fs::path sf = test::write_scene(tmp.path, "scene.json", scene);
    io::CalibrationSpec spec = io::parse_calibration(
        {{"scenario", sf.string()},
         {"stage", "nope"},
         {"targets", {{"young_modulus", 1e9}, {"poisson_ratio", 0.2}, {"tensile_strength", 1e6}}},
         {"initial", {{"radius_ratio", 0.5}, {"young_modulus", 1e9}}},
         {"write", "p.json"}},
        tmp.path);
    io::CalibrationOptions opt;
    opt.outdir = tmp.path / "out2";
    try {
      io::calibrate_beams(spec, test::registry(), opt);
      FAIL("no ConfigError");
    } catch (const ConfigError& e) {
      INFO(e.what());
      REQUIRE(e.diagnostics().size() == 2);
      CHECK(e.diagnostics()[0].path == "/bonds/params/failure");
      CHECK(e.diagnostics()[1].path == "/stages");
    }
  }
}

}  // namespace test_calibrate_beams
