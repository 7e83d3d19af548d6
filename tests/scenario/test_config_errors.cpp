/// Configuration errors: every class is reported with the JSON pointer of the offending value,
/// in process (io::load_scenario throws ConfigError with that Diagnostic path) and through the
/// executable (`sparkdem check` and `sparkdem run` exit with code 2, print the path on stderr and
/// create no output directory).
#include <catch2/catch.hpp>

#include "support/scratch.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace test_config_errors {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using sparkdem::ConfigError;

struct ScratchDir : sparkdem::test::ScratchDir {
  ScratchDir() : sparkdem::test::ScratchDir("sparkdem_cfgerr") {}
};

using sparkdem::test::registry;

/// A valid scene: lattice of 288 spheres in a box of five walls, then 10 steps under gravity.
json valid_scene() {
  std::ifstream in(fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/restart_pour.json");
  json j = json::parse(in);
  j["stages"][1]["stop"] = {{"steps", 10}};
  return j;
}

/// A scene with one generator stage (deposit or fill) and no scenario walls.
json generator_scene(const std::string& type, const json& generator) {
  json j = valid_scene();
  j["walls"] = json::array();
  j["stages"] = json::array({{{"name", "gen"}, {"type", type}, {"dt", 1e-9}, {"generator", generator}, {"stop", {{"steps", 10}}}}});
  return j;
}

struct CliResult {
  int code = -1;
  std::string err;
};

/// `sparkdem <args>` with stdout discarded and stderr captured.
CliResult cli(const std::string& args, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "OMP_NUM_THREADS=1 '" + std::string(SPARKDEM_BINARY) + "' " + args + " > /dev/null 2> '" + err.string() + "'";
  const int rc = std::system(cmd.c_str());
  CliResult r;
  if (rc != -1 && WIFEXITED(rc)) r.code = WEXITSTATUS(rc);
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

bool contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

/// The scenario file `scene` must be rejected by check and run with exit code 2 and every
/// (path, message fragment) pair on stderr; run must not create its output directory.
void expect_cli_rejects(const fs::path& scene, const std::vector<std::pair<std::string, std::string>>& expected, const fs::path& dir) {
  for (const std::string sub : {"check", "run"}) {
    const fs::path out = dir / ("out_" + sub);
    const CliResult r = cli(sub + " '" + scene.string() + "'" + (sub == "run" ? " --quiet -o '" + out.string() + "'" : ""), dir);
    INFO("sparkdem " << sub << " stderr:\n" << r.err);
    CHECK(r.code == 2);
    CHECK(contains(r.err, "configuration error"));
    for (const auto& [path, fragment] : expected) {
      CHECK(contains(r.err, path + ": "));
      CHECK(contains(r.err, fragment));
    }
    CHECK_FALSE(fs::exists(out));
  }
}

/// In process: load_scenario throws ConfigError holding each expected (path, fragment); then
/// the same through the executable.
void expect_rejected(const json& scene, const std::vector<std::pair<std::string, std::string>>& expected) {
  try {
    (void)sparkdem::io::load_scenario(scene, registry(), SPARKDEM_SOURCE_DIR);
    FAIL("load_scenario accepted an invalid scenario");
  } catch (const ConfigError& e) {
    INFO("diagnostics: " << e.what());
    CHECK(e.diagnostics().size() == expected.size());
    for (const auto& [path, fragment] : expected) {
      bool found = false;
      for (const auto& d : e.diagnostics()) found = found || (d.path == path && contains(d.message, fragment));
      CHECK(found);
    }
  }
  ScratchDir dir;
  const fs::path file = dir.path / "scene.json";
  std::ofstream(file) << scene.dump(2);
  expect_cli_rejects(file, expected, dir.path);
}

}  // namespace

TEST_CASE("the base scene of the error tests is valid", "[config_errors][scenario]") {
  // Reference point: without the mutation the scene loads (otherwise the tests below prove nothing).
  const auto sc = sparkdem::io::load_scenario(valid_scene(), registry(), SPARKDEM_SOURCE_DIR);
  CHECK(sc.stages.size() == 2);
  ScratchDir dir;
  const fs::path file = dir.path / "scene.json";
  std::ofstream(file) << valid_scene().dump(2);
  CHECK(cli("check '" + file.string() + "'", dir.path).code == 0);
}

TEST_CASE("each class of configuration error names its JSON path (exit 2, no output directory)", "[config_errors][scenario]") {
  SECTION("unknown key, with a did-you-mean") {
    json j = valid_scene();
    j["stages"][1]["dtt"] = 1e-5;
    expect_rejected(j, {{"/stages/1/dtt", "did you mean \"dt\""}});
  }
  SECTION("missing required key") {
    json j = valid_scene();
    j["materials"][0].erase("density");
    expect_rejected(j, {{"/materials/0/density", "missing required key \"density\""}});
  }
  SECTION("wrong type") {
    json j = valid_scene();
    j["stages"][1]["stop"]["time"] = "long";
    expect_rejected(j, {{"/stages/1/stop/time", "expected number, found \"long\""}});
  }
  SECTION("out-of-range value") {
    json j = valid_scene();
    j["contact"]["params"]["restitution"] = 1.5;
    expect_rejected(j, {{"/contact/params/restitution", "found 1.5"}});
  }
  SECTION("unknown contact law: the message lists every registered law") {
    json j = valid_scene();
    j["contact"]["law"] = "hertz_mindlinn";
    std::vector<std::pair<std::string, std::string>> expected = {{"/contact/law", "unknown contact law \"hertz_mindlinn\""}};
    for (const auto& [name, entry] : registry().laws()) expected.push_back({"/contact/law", name});
    REQUIRE(registry().laws().size() >= 3);
    try {
      (void)sparkdem::io::load_scenario(j, registry(), SPARKDEM_SOURCE_DIR);
      FAIL("accepted");
    } catch (const ConfigError& e) {
      REQUIRE(e.diagnostics().size() == 1);
      for (const auto& [path, fragment] : expected) CHECK(contains(e.diagnostics()[0].message, fragment));
    }
    ScratchDir dir;
    std::ofstream(dir.path / "scene.json") << j.dump(2);
    expect_cli_rejects(dir.path / "scene.json", expected, dir.path);
  }
  SECTION("motion of a wall that does not exist") {
    json j = valid_scene();
    j["stages"][1]["walls"] = {{"lid", {{"type", "velocity"}, {"speed", 0.1}}}};
    expect_rejected(j, {{"/stages/1/walls/lid", "no wall named \"lid\""}});
  }
  SECTION("table size distribution whose cumulative fractions end at 0.9, not 1") {
    const json table = {{"type", "table"}, {"diameters", {10e-6, 20e-6, 30e-6}}, {"cumulative_fraction", {0.2, 0.5, 0.9}}};
    // Particle count from the volume (0) and given explicitly: both must be caught at load.
    for (int n : {0, 50}) {
      INFO("particles = " << n);
      expect_rejected(generator_scene("deposit", {{"particles", n}, {"size_distribution", table}}),
                      {{"/stages/0/generator/size_distribution/cumulative_fraction", "last cumulative fraction is 0.9"}});
    }
  }
  SECTION("relax: particles = 0 needs a size distribution, and the distribution is checked at load") {
    const json base = {{"shape", "cylinder"}, {"radius", 20e-6}, {"length", 40e-6}, {"particles", 0}};
    expect_rejected(generator_scene("relax", base), {{"/stages/0/generator/particles", "needs particles >= 1"}});
    json gen = base;
    gen["size_distribution"] = {{"type", "table"}, {"diameters", {2e-6, 4e-6}}, {"cumulative_fraction", {0.2, 0.9}}};
    expect_rejected(generator_scene("relax", gen),
                    {{"/stages/0/generator/size_distribution/cumulative_fraction", "last cumulative fraction is 0.9"}});
  }
  SECTION("walls that do not enclose the lattice") {
    json j = valid_scene();
    j["stages"][0]["generator"]["hi"] = {0.03, 0.015, 0.02};  // 12 columns in x; the xhi wall is at 0.0175 m
    expect_rejected(j, {{"/stages/0/generator", "outside wall 'xhi'"}});
    // Above LatticeGenerator::kCheapParticles (401,931 points here) the check is the lattice's 8
    // corners, without generating it: the same wall is named, and an enclosed lattice loads.
    j["stages"][0]["generator"]["spacing"] = 2.5e-4;
    j["stages"][0]["generator"]["diameter"] = 2e-4;
    expect_rejected(j, {{"/stages/0/generator", "corner point (0.030000, 0.002500, 0.002500) lies outside wall 'xhi'"}});
    j["stages"][0]["generator"]["hi"] = {0.015, 0.015, 0.02};
    CHECK_NOTHROW(sparkdem::io::load_scenario(j, registry(), SPARKDEM_SOURCE_DIR));
  }
  SECTION("container too small for the requested particles") {
    // 5000 spheres of mean radius 0.1 mm (spread 0.125) in a 1 mm^3 box: solid fraction
    // 5000 * 4/3 pi (1e-4)^3 * (1 + 0.125^2) / 1e-9 = 21.3 > 0.74.
    const json gen = {{"shape", "box"}, {"lo", {0, 0, 0}}, {"hi", {1e-3, 1e-3, 1e-3}}, {"particles", 5000}, {"mean_radius", 1e-4}};
    expect_rejected(generator_scene("fill", gen), {{"/stages/0/generator/particles", "solid fraction 21.27 > 0.74"}});
    // The same particles at a tenth of the radius fit (fraction 0.021): no error.
    json ok = generator_scene("fill", gen);
    ok["stages"][0]["generator"]["mean_radius"] = 1e-5;
    CHECK_NOTHROW(sparkdem::io::load_scenario(ok, registry(), SPARKDEM_SOURCE_DIR));
  }
  SECTION("cylinder particle set: radius, axis and criterion are checked with their paths") {
    json j = valid_scene();
    j["particle_sets"] = {{"src", {{"type", "cylinder"}, {"axis", {0, 0, 0}}}},
                          {"neg", {{"type", "cylinder"}, {"radius", -1e-3}}},
                          {"crit", {{"type", "cylinder"}, {"radius", 1e-3}, {"criterion", "centre_inside"}}},
                          {"short", {{"type", "cylinder"}, {"radius", 1e-3}, {"axis_point", {0, 0}}}}};
    expect_rejected(j, {{"/particle_sets/src/radius", "a cylinder set needs radius > 0 [m], found nothing"},
                        {"/particle_sets/src/axis", "non-zero axis direction"},
                        {"/particle_sets/neg/radius", "found -0.001"},
                        {"/particle_sets/crit/criterion", "centre_inside"},
                        {"/particle_sets/short/axis_point", "expected an array of 3 numbers"}});
    json ok = valid_scene();
    ok["particle_sets"] = {{"src", {{"type", "cylinder"}, {"axis_point", {0.01, 0.01, 0}}, {"radius", 3e-3}, {"criterion", "overlap"}}}};
    CHECK_NOTHROW(sparkdem::io::load_scenario(ok, registry(), SPARKDEM_SOURCE_DIR));
  }
  SECTION("absurdly deep nesting is rejected before anything copies it") {
    // 100000 nested arrays: copying such a value recursively overflowed the stack (segfault).
    ScratchDir dir;
    const fs::path file = dir.path / "deep.json";
    std::string scene = valid_scene().dump();
    const std::string stop = "\"stop\":{\"steps\":10}";
    REQUIRE(scene.find(stop) != std::string::npos);
    scene.replace(scene.find(stop), stop.size(), stop + ",\"until\":" + std::string(100000, '[') + std::string(100000, ']'));
    std::ofstream(file) << scene;
    // Reported at the first value 32 levels below the root: /stages/1/until + 29 x "/0".
    std::string at = "/stages/1/until";
    for (int k = 0; k < 29; ++k) at += "/0";
    try {
      (void)sparkdem::io::load_scenario(sparkdem::io::read_json_file(file), registry(), SPARKDEM_SOURCE_DIR);
      FAIL("accepted");
    } catch (const ConfigError& e) {
      REQUIRE(e.diagnostics().size() == 1);
      CHECK(e.diagnostics()[0].path == at);
    }
    expect_cli_rejects(file, {{at, "nested more than 32 levels deep"}}, dir.path);
  }
  SECTION("several errors in one file are reported together") {
    json j = valid_scene();
    j["stages"][1]["dtt"] = 1e-5;
    j["contact"]["params"]["restitution"] = -0.5;
    j["materials"][0].erase("density");
    j["walls"][2]["normal"] = {1, 0};
    expect_rejected(j, {{"/stages/1/dtt", "did you mean"},
                        {"/contact/params/restitution", "found -0.5"},
                        {"/materials/0/density", "missing required key"},
                        {"/walls/2/normal", "expected an array of 3 numbers"}});
  }
}

TEST_CASE("the retired absolute gap keys of the CPC modules are refused, naming their relative replacement", "[config_errors][scenario]") {
  json j = sparkdem::test::load_data("cpc_small.json");
  auto& m = j["stages"][0]["modules"];
  m["contact_percolation"].erase("touch_gap_rel");
  m["contact_percolation"]["touch_tolerance"] = 2e-3;
  m["ptc_strain"]["break_gap"] = 2e-3;
  m["ptc_strain"]["min_gap"] = 0.01;
  // electrical_network keeps its absolute touch_tolerance (shared with other scenes): accepted.
  expect_rejected(j, {{"/stages/0/modules/contact_percolation/touch_tolerance", "give touch_gap_rel instead of touch_tolerance"},
                      {"/stages/0/modules/ptc_strain/break_gap", "give break_gap_rel instead of break_gap"},
                      {"/stages/0/modules/ptc_strain/min_gap", "give min_gap_rel instead of min_gap"}});
  // ptc_self_heating shares the keys; the bonded matrix cannot follow closing pairs beyond its springs.
  json h = sparkdem::test::load_data("ptc_self_heating_small.json");
  h["stages"][1]["modules"]["ptc_self_heating"]["cutoff_gap"] = 5e-6;
  expect_rejected(h, {{"/stages/1/modules/ptc_self_heating/cutoff_gap", "give cutoff_gap_rel instead of cutoff_gap"}});
  json b = sparkdem::test::load_data("cpc_small.json");
  b["stages"][0]["modules"]["ptc_strain"]["closing_gap_rel"] = 0.6;
  expect_rejected(b, {{"/stages/0/modules/ptc_strain/closing_gap_rel", "must not exceed it, found 0.6"}});
}

TEST_CASE("unreadable and malformed scenario files exit with code 2", "[config_errors][scenario]") {
  ScratchDir dir;
  SECTION("unreadable file") {
    const fs::path missing = dir.path / "no_such_scene.json";
    CHECK_THROWS_AS(sparkdem::io::read_json_file(missing), ConfigError);
    expect_cli_rejects(missing, {{"/", "cannot read the scenario file"}, {"/", "no_such_scene.json"}}, dir.path);
  }
  SECTION("malformed JSON: the message gives line and column") {
    const fs::path bad = dir.path / "bad.json";
    std::ofstream(bad) << "{\n  \"name\": \"x\",\n  \"seed\": ,\n}\n";  // value missing at line 3, column 11
    try {
      (void)sparkdem::io::read_json_file(bad);
      FAIL("accepted");
    } catch (const ConfigError& e) { CHECK(contains(e.what(), "line 3, column 11")); }
    expect_cli_rejects(bad, {{"/", "is not valid JSON"}, {"/", "line 3, column 11"}}, dir.path);
  }
  SECTION("a number beyond the double range is invalid JSON, not an internal error") {
    const fs::path big = dir.path / "big.json";
    std::ofstream(big) << "{\"name\": \"x\", \"seed\": 1e400}\n";  // nlohmann throws out_of_range, not parse_error
    CHECK_THROWS_AS(sparkdem::io::read_json_file(big), ConfigError);
    expect_cli_rejects(big, {{"/", "is not valid JSON"}, {"/", "1e400"}}, dir.path);
  }
}

TEST_CASE("bond, clock and create_bonds errors are reported together with their paths", "[config_errors][scenario][contracts]") {
  // The same keys, valid, are accepted (so each error below comes from the one value changed).
  json ok = valid_scene();
  ok["bonds"] = {{"law", "spring_bond"}, {"contact_rule", "add"}};
  ok["stages"][1]["create_bonds"] = {{"gap_tolerance", 0.0}};
  ok["stages"][1]["time_scale"] = 10.0;
  ok["stages"][1]["modules"]["gravity"]["clock"] = {{"kind", "every_step"}};
  ok["stages"][1]["snapshots"] = {{"column", "bonds_broken"}, {"at", {1.0}}};  // a bond column, known at load
  CHECK_NOTHROW(sparkdem::io::load_scenario(ok, registry(), SPARKDEM_SOURCE_DIR));
  json j = valid_scene();
  j["bonds"] = {{"law", "spring_bnd"}, {"contact_rule", "sometimes"}};
  j["stages"][1]["create_bonds"] = {{"gap_tolerance", -1.0}};
  j["stages"][1]["modules"]["gravity"]["clock"] = {{"kind", "on_event"}};
  expect_rejected(j, {{"/bonds/law", "did you mean \"spring_bond\""},
                      {"/bonds/contact_rule", "found \"sometimes\""},
                      {"/stages/1/create_bonds/gap_tolerance", "expected a value >= 0 [m], found -1"},
                      {"/stages/1/modules/gravity/clock", "needs a condition"}});
  json k = valid_scene();
  k["stages"][1]["create_bonds"] = {{"gap_tolerance", 0.0}};  // no bond law in the scenario
  k["stages"][1]["modules"]["gravity"]["clock"] = {{"kind", "every_step"}, {"moved_beyond", 1e-3}};
  k["stages"][1]["time_scale"] = 0.0;
  expect_rejected(k, {{"/stages/1/create_bonds", "needs a bond law"},
                      {"/stages/1/modules/gravity/clock/kind", "not \"on_event\""},
                      {"/stages/1/time_scale", "found 0"}});
}

TEST_CASE("$include merges a JSON file into an object, keys beside it override, a bad include names its path",
          "[config_errors][scenario]") {
  ScratchDir dir;
  json scene = valid_scene();
  // The contact law's parameters come from a material file in a subdirectory, which itself
  // includes a second file; the scenario overrides one value.
  fs::create_directories(dir.path / "materials");
  json params = scene["contact"]["params"];
  json base = params;
  base.erase("friction");
  base["$sources"] = {{"youngs_modulus", "an annotation, dropped by the loader"}};
  sparkdem::test::write_scene(dir.path / "materials", "base.json", base);
  sparkdem::test::write_scene(dir.path / "materials", "law.json", {{"$include", "base.json"}, {"friction", 0.25}});
  scene["contact"]["params"] = {{"$include", "materials/law.json"}, {"friction", 0.125}};
  const auto sc = sparkdem::io::load_scenario(scene, registry(), dir.path);
  json expected = params;
  expected["friction"] = 0.125;
  for (auto it = expected.begin(); it != expected.end(); ++it) CHECK(sc.resolved["contact"]["params"][it.key()] == it.value());
  // A missing file and a non-object file: both reported, with their JSON paths.
  sparkdem::test::write_scene(dir.path, "list.json", json::array({1, 2}));
  scene["contact"]["params"] = {{"$include", "nowhere.json"}};
  scene["stages"][0]["$include"] = "list.json";
  try {
    (void)sparkdem::io::load_scenario(scene, registry(), dir.path);
    FAIL("a missing include was accepted");
  } catch (const ConfigError& e) {
    INFO(e.what());
    REQUIRE(e.diagnostics().size() == 2);
    CHECK(e.diagnostics()[0].path + e.diagnostics()[1].path != "");
    bool missing = false, not_object = false;
    for (const auto& d : e.diagnostics()) {
      missing = missing || (d.path == "/contact/params/$include" && contains(d.message, "cannot read"));
      not_object = not_object || (d.path == "/stages/0/$include" && contains(d.message, "JSON object"));
    }
    CHECK(missing);
    CHECK(not_object);
  }
  const fs::path file = sparkdem::test::write_scene(dir.path, "scene.json", scene);
  expect_cli_rejects(file, {{"/contact/params/$include", "cannot read"}, {"/stages/0/$include", "JSON object"}}, dir.path);
}

}  // namespace test_config_errors
