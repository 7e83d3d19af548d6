/// The adaptive step (issue 62, StageConfig::adaptive, stage key "dt": {"adaptive": F}): two steel
/// spheres between two plane walls, the top wall pressed in at 0.5 m/s, so that Hertz contacts
/// stiffen (k ~ delta^1/2: the network's stable step falls as delta^-1/4). At a fixed
/// dt_fraction 0.9 the stability check stops the run (exit 3); with an adaptive 0.9 the run
/// follows the state to its end, lands on its stop time and frame times, is independent of the
/// thread count and agrees with a fixed-step run at a quarter of its smallest step.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

namespace test_adaptive_dt {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json run(const json& scene, const fs::path& out, int threads = 1, const std::optional<fs::path>& restart = {}) {
  return test::run_scene(scene, out.parent_path(), out, restart, threads);
}

/// Two spheres (R = 1 mm, steel, Hertz-Mindlin without friction, restitution `e`) stacked between
/// planes at z = 1 and 5 mm, touching both; the top plane moves in at 0.5 m/s for 1.9 ms (to an overlap of
/// about 0.37 R). `dt`: the press stage's dt key.
json two_spheres(const json& dt, double e = 0.9) {
  json j = json::parse(R"({
    "name": "two_spheres_hertz", "seed": 1,
    "materials": [{"name": "steel", "density": 7800}],
    "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": 2e11, "poisson_ratio": 0.3, "restitution": 0.9, "friction": 0.0}},
    "walls": [{"name": "bottom", "type": "plane", "point": [0, 0, 0.001], "normal": [0, 0, 1]},
              {"name": "top", "type": "plane", "point": [0, 0, 0.005], "normal": [0, 0, -1]}],
    "stages": [
      {"name": "create", "type": "lattice", "generator": {"lo": [0, 0, 0.0015], "hi": [0.0001, 0.0001, 0.0045], "spacing": 0.002, "diameter": 0.002}},
      {"name": "press", "type": "dynamics", "stability_check_every": 50,
       "walls": {"top": {"type": "velocity", "speed": 0.5}},
       "stop": {"time": 0.0019}, "output": {"timeseries_every": 50}}
    ]})");
  j["stages"][1]["dt"] = dt;
  j["contact"]["params"]["restitution"] = e;
  return j;
}

/// The comma-separated fields of a CSV line (no quoting: timeseries.csv has none).
std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> out;
  for (std::size_t a = 0, b; a <= line.size(); a = b + 1) {
    b = line.find(',', a);
    if (b == std::string::npos) b = line.size();
    out.push_back(line.substr(a, b - a));
  }
  return out;
}

/// The energy balance of a two_spheres run at its end: (W - KE - U) / W, W the walls' work, KE the
/// kinetic energy, U the Hertz energy of the three contacts, (8/15) E* sqrt(R*) delta^(5/2) with
/// E* = E / (2 (1 - nu^2)) for the pair and the walls (the law's wall contact), R* = R/2 and R.
double energy_error(const fs::path& out, const json& stage) {
  const auto h5 = io::H5File::open_read(out / "final_state.h5");
  const auto x = h5.read_doubles("state/particles/position"), v = h5.read_doubles("state/particles/velocity"),
             m = h5.read_doubles("state/particles/mass");
  REQUIRE(m.size() == 2);
  double ke = 0.0;
  for (std::size_t i = 0; i < 2; ++i) ke += 0.5 * m[i] * (v[3 * i] * v[3 * i] + v[3 * i + 1] * v[3 * i + 1] + v[3 * i + 2] * v[3 * i + 2]);
  const double r = 1e-3, es = 2e11 / (2.0 * (1.0 - 0.09));
  const double z0 = std::min(x[2], x[5]), z1 = std::max(x[2], x[5]);
  const double top = 0.005 - stage["final"]["wall_top_offset"].get<double>();
  const double d[3] = {r - (z0 - 0.001), 2.0 * r - (z1 - z0), r - (top - z1)}, R[3] = {r, 0.5 * r, r};
  double u = 0.0;
  for (int k = 0; k < 3; ++k) u += 8.0 / 15.0 * es * std::sqrt(R[k]) * std::pow(std::max(d[k], 0.0), 2.5);
  const double w = stage["final"]["wall_top_work"].get<double>() + stage["final"]["wall_bottom_work"].get<double>();
  return (w - ke - u) / w;
}

}  // namespace

TEST_CASE("adaptive dt: stiffening Hertz contacts stop a fixed 0.9 and are followed by an adaptive 0.9", "[adaptive][scenario]") {
  test::ScratchDir tmp("sparkdem_adaptive");
  // Fixed: the stable step of the stiffened state falls below the step chosen at the start.
  json fixed = two_spheres(json());
  fixed["stages"][1].erase("dt");
  fixed["stages"][1]["dt_fraction"] = 0.9;
  bool stopped = false;
  try {
    run(fixed, tmp.path / "fixed");
  } catch (const PhysicsError& e) {
    stopped = true;
    CHECK(e.quantity() == "time step");
  }
  CHECK(stopped);

  // Adaptive: runs to the stop time, the step shrinking with the stable step.
  const json a = run(two_spheres({{"adaptive", 0.9}, {"check_every", 50}}), tmp.path / "adaptive");
  REQUIRE(a["status"] == "completed");
  const json& st = a["stages"][1];
  const json& ad = st["dt_adaptive"];
  INFO(ad.dump());
  CHECK(st["simulated_time_s"].get<double>() == 0.0019);  // the last step lands on stop.time
  CHECK(ad["overshoots"] == 0);                            // never above the state's stable step at a check
  const double first = st["dt_s"].get<double>(), smallest = ad["min_s"].get<double>();
  CHECK(ad["max_s"].get<double>() == first);
  CHECK(smallest < 0.65 * first);  // the Hertz network stiffened: overlap 0.37 R at the end
  CHECK(st["final"]["max_overlap_ratio"].get<double>() > 0.3);
  // The dt column follows the step: non-increasing here (the press only stiffens), first value the first step.
  std::ifstream ts(tmp.path / "adaptive" / "timeseries.csv");
  std::string header, line;
  std::getline(ts, header);
  CHECK(header.find(",dt") != std::string::npos);

  // The same run at a quarter of the smallest adaptive step, fixed: the wall force at the end
  // agrees to the integration error (second order in the step).
  json fine = two_spheres(0.25 * smallest);
  const json f = run(fine, tmp.path / "fine");
  const double F_a = st["final"]["wall_top_normal_force"].get<double>(), F_f = f["stages"][1]["final"]["wall_top_normal_force"].get<double>();
  INFO("top wall force: adaptive " << F_a << " N, fixed at dt_min / 4 " << F_f << " N");
  CHECK(std::abs(F_a - F_f) <= 1e-3 * std::abs(F_f));

  // Energy (e = 1: no damping): the adaptive run's balance error against the fixed run's at the adaptive
  // run's smallest step. The adaptive run takes larger steps for most of the press, so its error
  // may be somewhat larger: within a factor 2 of the fixed run's (both ~4e-4 here).
  const json undamped = run(two_spheres({{"adaptive", 0.9}, {"check_every", 50}}, 1.0), tmp.path / "undamped");
  const json at_min = run(two_spheres(undamped["stages"][1]["dt_adaptive"]["min_s"], 1.0), tmp.path / "at_min");
  const double e_a = energy_error(tmp.path / "undamped", undamped["stages"][1]), e_m = energy_error(tmp.path / "at_min", at_min["stages"][1]);
  INFO("energy balance error: adaptive " << e_a << ", fixed at the smallest adaptive step " << e_m);
  CHECK(std::abs(e_a) <= 2.0 * std::abs(e_m));
  CHECK(std::abs(e_a) < 1e-3);
}

TEST_CASE("adaptive dt: a softening state grows the step by at most `growth` per check, up to F x the stable step", "[adaptive][scenario]") {
  // The pressed pair, then released: the top wall backs off at 1 m/s, the overlaps relax and the
  // stable step grows back to the a-priori (Rayleigh) step of the free spheres.
  test::ScratchDir tmp("sparkdem_adaptive_release");
  const double growth = 1.02;
  json scene = two_spheres({{"adaptive", 0.9}, {"check_every", 25}});
  json release = scene["stages"][1];
  release["name"] = "release";
  release["dt"] = {{"adaptive", 0.9}, {"check_every", 25}, {"growth", growth}};
  release["walls"]["top"]["speed"] = -1.0;
  release["stop"] = {{"time", 0.0012}};
  release["output"]["timeseries_every"] = 25;  // a row after every check: the step it chose
  scene["stages"].push_back(release);
  const json sum = run(scene, tmp.path / "out");
  REQUIRE(sum["status"] == "completed");
  const json& st = sum["stages"][2];
  const double press_end = sum["stages"][1]["dt_adaptive"]["min_s"].get<double>();
  // The release starts at F x the stable step of the compressed state (the press's last step, or
  // within one check of it) and ends at F x the a-priori step of the free spheres (the press's first).
  const double first = st["dt_s"].get<double>(), free = sum["stages"][1]["dt_s"].get<double>();
  CHECK(first < 0.7 * free);
  CHECK(first <= press_end * 1.1);
  CHECK(st["dt_adaptive"]["max_s"].get<double>() == free);
  // Row by row (one check each): the step grows by at most `growth`, and by exactly `growth`
  // while F x the stable step is further than that.
  std::ifstream in(tmp.path / "out" / "timeseries.csv");
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> cols = split_csv(line);
  const auto col = [&](const std::string& c) { return static_cast<std::size_t>(std::find(cols.begin(), cols.end(), c) - cols.begin()); };
  const std::size_t c_dt = col("dt"), c_stage = col("stage");
  REQUIRE(c_dt < cols.size());
  std::vector<double> dts;
  while (std::getline(in, line)) {
    const std::vector<std::string> v = split_csv(line);
    if (std::stod(v[c_stage]) == 2.0) dts.push_back(std::stod(v[c_dt]));
  }
  REQUIRE(dts.size() > 20);
  std::size_t grown_at_bound = 0;
  for (std::size_t k = 1; k < dts.size(); ++k) {
    INFO("row " << k << ": " << dts[k - 1] << " -> " << dts[k]);
    CHECK(dts[k] <= dts[k - 1] * growth * (1.0 + 1e-15));
    grown_at_bound += dts[k] == dts[k - 1] * growth;
  }
  INFO("rows grown at the bound: " << grown_at_bound << " of " << dts.size() - 1);
  CHECK(grown_at_bound >= 5);  // the growth bound, not the state, set the pace for a while
  CHECK(dts.back() == free);
}

TEST_CASE("adaptive dt: frames land on frame_every_s, results do not depend on the thread count, a restart continues bit for bit",
          "[adaptive][restart][scenario]") {
  test::ScratchDir tmp("sparkdem_adaptive_frames");
  json scene = two_spheres({{"adaptive", 0.9}, {"check_every", 37}, {"growth", 1.05}});
  scene["stages"][1]["output"]["frame_every_s"] = 0.0004;
  const json one = run(scene, tmp.path / "one", 1);
  REQUIRE(one["status"] == "completed");
  // Frames at the stage start, at 0.4, 0.8, 1.2, 1.6 ms (exactly: steps shortened to land) and the end.
  std::vector<double> times;
  for (const auto& e : fs::directory_iterator(tmp.path / "one" / "frames"))
    times.push_back(io::H5File::open_read(e.path()).attribute_double("/", "time"));
  std::sort(times.begin(), times.end());
  REQUIRE(times.size() == 7);  // the lattice frame, the press start, 4 timed frames, the end
  for (int n = 1; n <= 4; ++n) CHECK(times[static_cast<std::size_t>(n) + 1] == n * 0.0004);
  CHECK(times.back() == 0.0019);

  const json two = run(scene, tmp.path / "two", 2);
  test::require_identical_state(tmp.path / "one" / "final_state.h5", tmp.path / "two" / "final_state.h5", {"pipeline/record"});

  json split = scene;
  split["stages"][1]["output"]["checkpoint_every"] = 1111;  // inside the press, between two checks
  run(split, tmp.path / "split");
  const json again = run(scene, tmp.path / "restarted", 1, tmp.path / "split" / "checkpoint.h5");
  REQUIRE(again["status"] == "completed");
  test::require_identical_state(tmp.path / "one" / "final_state.h5", tmp.path / "restarted" / "final_state.h5", {"pipeline/record"});
  // The resumed stage's statistics cover its whole history (the checkpoint carries it).
  const json& press = again["stages"].back();
  REQUIRE(press["name"] == "press");
  CHECK(press["dt_adaptive"]["min_s"] == one["stages"][1]["dt_adaptive"]["min_s"]);
  CHECK(press["dt_adaptive"]["median_s"] == one["stages"][1]["dt_adaptive"]["median_s"]);
}

TEST_CASE("adaptive dt: bad keys are errors at their paths", "[adaptive][config_errors]") {
  const auto rejects = [](const json& dt, const std::string& path, const std::string& fragment, bool with_fraction = false) {
    json scene = two_spheres(dt);
    if (with_fraction) scene["stages"][1]["dt_fraction"] = 0.5;
    try {
      (void)io::load_scenario(scene, test::registry(), fs::temp_directory_path());
      FAIL("accepted " << dt.dump());
    } catch (const ConfigError& e) {
      INFO(e.what());
      bool found = false;
      for (const auto& d : e.diagnostics()) found = found || (d.path == path && d.message.find(fragment) != std::string::npos);
      CHECK(found);
    }
  };
  rejects(json::object({{"check_every", 10}}), "/stages/1/dt/adaptive", "required");
  rejects({{"adaptive", 1.5}}, "/stages/1/dt/adaptive", "");
  rejects({{"adaptive", 0.9}, {"min", 1e-6}, {"max", 1e-7}}, "/stages/1/dt/min", "dt.min <= dt.max");
  rejects({{"adaptive", 0.9}}, "/stages/1/dt_fraction", "adaptive", true);
  rejects({{"adaptive", 0.9}, {"grow", 2}}, "/stages/1/dt/grow", "");
}

TEST_CASE("adaptive dt: a state that needs less than dt.min stops the run with the quantity", "[adaptive][scenario]") {
  test::ScratchDir tmp("sparkdem_adaptive_min");
  bool stopped = false;
  try {
    run(two_spheres({{"adaptive", 0.9}, {"min", 8e-7}}), tmp.path / "out");
  } catch (const PhysicsError& e) {
    stopped = true;
    CHECK(e.quantity() == "time step");
    CHECK(std::string(e.what()).find("dt.min") != std::string::npos);
  }
  CHECK(stopped);
}

}  // namespace test_adaptive_dt
