/// Snapshots, sweeps and ensembles (issue 3 point 4), through the `sparkdem` executable.
///
/// Invariants under test:
///  - a snapshot is taken at the first check where its column reaches the value, and its state
///    file holds exactly the state (every item State::visit writes) of an uninterrupted run
///    stopped at that step;
///  - an item of a sweep over snapshots starts from its snapshot (its first time-series row is
///    the free-fall closed form at the snapshot time) and continues the free fall;
///  - a parameter sweep of the gravity on a free fall gives v = g t in every row;
///  - a seed ensemble item equals a plain run with that scenario seed (reseeding is the only
///    difference), its rows differ, and summary.json's mean and sample standard deviation are
///    those of the rows; a rerun reproduces the rows bit for bit;
///  - a sweep is a branch: the stage after it continues from the state before it;
///  - a restart neither retakes nor loses snapshots and resumes a sweep inside its item with the
///    rows before it, ending with the same table and final state as the uninterrupted run;
///  - every sweep configuration error is reported at once with its JSON path.
#include <catch2/catch.hpp>

#include "support/scratch.hpp"
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/error.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"

namespace test_sweeps {

namespace {
using sparkdem::test::load_data;
using sparkdem::test::write_scene;

namespace fs = std::filesystem;
using nlohmann::json;
using sparkdem::test::registry;

struct ScratchDir : sparkdem::test::ScratchDir {
  ScratchDir() : sparkdem::test::ScratchDir("sparkdem_sweeps") {}
};


struct Cli {
  int code = -1;
  std::string err;
};

/// `sparkdem <args>` on one thread; stdout discarded, stderr kept.
Cli cli(const std::string& args, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=1 '" + std::string(SPARKDEM_BINARY) + "' " + args + " > /dev/null 2> '" +
                          err.string() + "'";
  const int rc = std::system(cmd.c_str());
  Cli r;
  if (rc != -1 && WIFEXITED(rc)) r.code = WEXITSTATUS(rc);
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

/// Runs `scene` into `out`; REQUIREs success.
void run(const fs::path& scene, const fs::path& out, const fs::path& dir, const std::string& extra = "") {
  const Cli r = cli("run " + sparkdem::test::shell_quoted(scene) + " -o " + sparkdem::test::shell_quoted(out) + " --quiet " + extra, dir);
  INFO("sparkdem run " << scene << " " << extra << " -> " << r.code << "; stderr:\n" << r.err);
  REQUIRE(r.code == 0);
}

json read_json(const fs::path& file) {
  std::ifstream in(file);
  REQUIRE(in);
  return json::parse(in);
}

/// Rows of a CSV file without quoted cells.
std::vector<std::vector<std::string>> read_csv(const fs::path& file) {
  std::ifstream in(file);
  REQUIRE(in);
  std::vector<std::vector<std::string>> rows;
  for (std::string line; std::getline(in, line);) {
    REQUIRE(line.find('"') == std::string::npos);
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}

/// Column `name` of the first data row of a CSV file, as a number.
double first_row_value(const fs::path& file, const std::string& name) {
  const auto rows = read_csv(file);
  REQUIRE(rows.size() >= 2);
  for (std::size_t c = 0; c < rows[0].size(); ++c)
    if (rows[0][c] == name) return std::stod(rows[1][c]);
  FAIL("no column " << name << " in " << file);
  return 0.0;
}

/// Records every item a State writes into a checkpoint, as raw bytes.
class RecordingArchive final : public sparkdem::Archive {
 public:
  std::map<std::string, std::vector<unsigned char>> items;
  bool reading() const override { return false; }
  bool has(const std::string&) const override { return false; }
  void visit(const std::string& n, std::vector<double>& v, int c) override { keep(n, v.data(), v.size() * sizeof(double), c); }
  void visit(const std::string& n, std::vector<std::int64_t>& v, int c) override { keep(n, v.data(), v.size() * 8, c); }
  void visit(const std::string& n, double& x) override { keep(n, &x, sizeof x, 0); }
  void visit(const std::string& n, std::int64_t& x) override { keep(n, &x, sizeof x, 0); }
  void visit(const std::string& n, std::string& s) override { keep(n, s.data(), s.size(), 0); }

 private:
  void keep(const std::string& n, const void* p, std::size_t bytes, int components) {
    std::vector<unsigned char> b(bytes + 1);
    if (bytes) std::memcpy(b.data(), p, bytes);
    b[bytes] = static_cast<unsigned char>(components);
    items[n] = std::move(b);
  }
};

/// The state in a checkpoint-format file: every item State::visit stores, read back.
std::map<std::string, std::vector<unsigned char>> state_items(const fs::path& file) {
  sparkdem::State s;
  sparkdem::io::read_checkpoint(file, s);
  RecordingArchive ar;
  s.visit(ar);
  REQUIRE(ar.items.count("state/particles/position") == 1);
  REQUIRE(ar.items.count("state/rng") == 1);
  return ar.items;
}

/// Same state, item by item (reports the first differing item).
void require_same_state(const fs::path& a, const fs::path& b) {
  const auto x = state_items(a), y = state_items(b);
  std::vector<std::string> nx, ny;
  for (const auto& [k, v] : x) nx.push_back(k);
  for (const auto& [k, v] : y) ny.push_back(k);
  REQUIRE(nx == ny);
  for (const auto& [k, v] : x) {
    INFO("item " << k << " of " << a << " vs " << b);
    CHECK(v == y.at(k));
  }
}

bool close_rel(double a, double b, double rel) { return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b)); }

std::string pipeline_record(const fs::path& checkpoint) {
  return sparkdem::io::H5File::open_read(checkpoint).read_string("/pipeline/record");
}

constexpr double kDt = 1e-4, kG = 9.81;

/// sweep_fall.json: 8 spheres 0.5 m above the floor fall freely (no contact within the test):
/// `fall` runs 300 steps with snapshots when `time` reaches 0.0042, 0.0118 and 0.0231 s
/// (checked every 10 steps); `more` runs 100 steps from each snapshot; `after` 50 steps.
/// Snapshot k is at the first multiple of 10 steps whose time reaches its value.
std::vector<std::int64_t> expected_snapshot_steps(const json& scene) {
  std::vector<std::int64_t> steps;
  for (const auto& a : scene["stages"][1]["snapshots"]["at"]) {
    std::int64_t n = 10;
    while (static_cast<double>(n) * kDt < a.get<double>()) n += 10;
    steps.push_back(n);
  }
  return steps;
}

}  // namespace

TEST_CASE("snapshots of a free fall at three times and a sweep over them", "[sweeps][scenario]") {
  ScratchDir tmp;
  const json scene = load_data("sweep_fall.json");
  const fs::path A = tmp.path / "A";
  run(write_scene(tmp.path, "fall.json", scene), A, tmp.path);
  const json sum = read_json(A / "summary.json");
  const auto steps = expected_snapshot_steps(scene);
  REQUIRE(steps == std::vector<std::int64_t>{50, 120, 240});

  // The snapshots: step, time and column value when taken, listed in summary.json.
  const json& snaps = sum["stages"][1]["snapshots"];
  CHECK(snaps["column"] == "time");
  CHECK(snaps["not_reached"].empty());
  REQUIRE(snaps["taken"].size() == 3);
  for (std::size_t k = 0; k < 3; ++k) {
    const json& t = snaps["taken"][k];
    CHECK(t["index"] == k);
    CHECK(t["step"] == steps[k]);
    CHECK(t["time"].get<double>() == static_cast<double>(steps[k]) * kDt);
    CHECK(t["value"] == t["time"]);
    CHECK(t["file"] == "snapshots/fall_" + std::to_string(k) + ".h5");
  }

  // Each snapshot file holds the state of an uninterrupted run stopped at its step.
  for (std::size_t k = 0; k < 3; ++k) {
    json cut = scene;
    cut["stages"] = json::array({scene["stages"][0], scene["stages"][1]});
    cut["stages"][1].erase("snapshots");
    cut["stages"][1]["stop"]["steps"] = steps[k];
    const fs::path B = tmp.path / ("cut" + std::to_string(k));
    run(write_scene(tmp.path, "cut" + std::to_string(k) + ".json", cut), B, tmp.path);
    require_same_state(A / "snapshots" / ("fall_" + std::to_string(k) + ".h5"), B / "final_state.h5");
  }

  // The sweep: one row per snapshot, each item starting from its snapshot.
  const json& sw = sum["stages"][2]["sweep"];
  CHECK(sw["kind"] == "snapshots");
  CHECK(sw["snapshots_of"] == "fall");
  CHECK(sw["table"] == "sweep_more.csv");
  REQUIRE(sw["rows"].size() == 3);
  const auto csv = read_csv(A / "sweep_more.csv");
  REQUIRE(csv.size() == 4);
  CHECK(csv[0] == std::vector<std::string>{"item", "snapshot", "snapshot_step", "snapshot_time", "snapshot_value", "status", "step", "time",
                                           "kinetic_energy_per_mass", "max_speed"});
  for (std::size_t k = 0; k < 3; ++k) {
    INFO("item " << k);
    const json& row = sw["rows"][k];
    const double t0 = snaps["taken"][k]["time"].get<double>();
    CHECK(row["status"] == "completed");
    CHECK(row["snapshot"] == snaps["taken"][k]["file"]);
    CHECK(row["snapshot_step"] == steps[k]);
    CHECK(row["snapshot_time"].get<double>() == t0);
    CHECK(row["steps"] == 100);
    // First time-series row of the item = the snapshot's state: free fall v = g t0.
    const fs::path ts = A / row["directory"].get<std::string>() / "timeseries.csv";
    CHECK(first_row_value(ts, "step") == static_cast<double>(steps[k]));
    CHECK(first_row_value(ts, "time") == t0);
    CHECK(close_rel(first_row_value(ts, "max_speed"), kG * t0, 1e-12));
    CHECK(close_rel(first_row_value(ts, "kinetic_energy_per_mass"), 0.5 * kG * kG * t0 * t0, 1e-12));
    // 100 more steps of free fall.
    const double t1 = t0 + 100 * kDt;
    const json& v = row["values"];
    CHECK(v["step"].get<double>() == static_cast<double>(steps[k] + 100));
    CHECK(close_rel(v["time"].get<double>(), t1, 1e-12));
    CHECK(close_rel(v["max_speed"].get<double>(), kG * t1, 1e-10));
    CHECK(close_rel(v["kinetic_energy_per_mass"].get<double>(), 0.5 * kG * kG * t1 * t1, 1e-10));
    // The CSV row holds the same numbers (17 significant digits read back exactly).
    const auto& c = csv[k + 1];
    CHECK(c[0] == std::to_string(k));
    CHECK(c[1] == row["snapshot"].get<std::string>());
    CHECK(std::stod(c[2]) == static_cast<double>(steps[k]));
    CHECK(std::stod(c[3]) == t0);
    CHECK(c[5] == "completed");
    CHECK(std::stod(c[6]) == v["step"].get<double>());
    CHECK(std::stod(c[7]) == v["time"].get<double>());
    CHECK(std::stod(c[8]) == v["kinetic_energy_per_mass"].get<double>());
    CHECK(std::stod(c[9]) == v["max_speed"].get<double>());
  }
  // A sweep is a branch: `after` continues from the end of `fall` (step 300), not from an item.
  const json& after = sum["stages"][3]["final"];
  CHECK(after["step"] == 350);
  CHECK(close_rel(after["max_speed"].get<double>(), kG * 350 * kDt, 1e-10));
}

TEST_CASE("a restart neither retakes nor loses snapshots and resumes a sweep inside its item", "[sweeps][restart][scenario]") {
  ScratchDir tmp;
  const json scene = load_data("sweep_fall.json");
  const fs::path A = tmp.path / "A";
  run(write_scene(tmp.path, "plain.json", scene), A, tmp.path);
  const json a = read_json(A / "summary.json");
  const json& a_rows = a["stages"][2]["sweep"]["rows"];

  SECTION("checkpoint in the snapshot stage, between the second and the third snapshot") {
    json ck = scene;
    ck["stages"][1]["output"]["checkpoint_every"] = 200;
    const fs::path f = write_scene(tmp.path, "ck.json", ck), B = tmp.path / "B", C = tmp.path / "C";
    run(f, B, tmp.path);
    CHECK(sparkdem::io::H5File::open_read(B / "checkpoint.h5").read_int64("/state/step") == 200);
    const json rec = json::parse(pipeline_record(B / "checkpoint.h5"));
    CHECK(rec["snapshots"].size() == 2);
    CHECK(rec["sweep"].is_null());
    run(f, C, tmp.path, "--restart " + sparkdem::test::shell_quoted(B / "checkpoint.h5"));
    const json c = read_json(C / "summary.json");
    const json& taken = c["stages"][0]["snapshots"]["taken"];
    REQUIRE(taken.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) CHECK(taken[k]["step"] == a["stages"][1]["snapshots"]["taken"][k]["step"]);
    // The two taken before the checkpoint stay in B (not retaken); the third is taken in C.
    CHECK(taken[0]["file"] == fs::absolute(B / "snapshots/fall_0.h5").lexically_normal().string());
    CHECK(taken[1]["file"] == fs::absolute(B / "snapshots/fall_1.h5").lexically_normal().string());
    CHECK(taken[2]["file"] == "snapshots/fall_2.h5");
    CHECK_FALSE(fs::exists(C / "snapshots/fall_0.h5"));
    require_same_state(A / "snapshots/fall_2.h5", C / "snapshots/fall_2.h5");
    const json& rows = c["stages"][1]["sweep"]["rows"];
    REQUIRE(rows.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) CHECK(rows[k]["values"] == a_rows[k]["values"]);
    require_same_state(A / "final_state.h5", C / "final_state.h5");
  }

  SECTION("checkpoint inside the second item of the sweep") {
    // Items run global steps 50-150, 120-220 and 240-340: step 200 lies in item 1 only.
    json ck = scene;
    ck["stages"][2]["output"]["checkpoint_every"] = 200;
    const fs::path f = write_scene(tmp.path, "ck.json", ck), D = tmp.path / "D", E = tmp.path / "E";
    run(f, D, tmp.path);
    {
      const auto h = sparkdem::io::H5File::open_read(D / "checkpoint.h5");
      CHECK(h.read_int64("/state/step") == 200);
      CHECK(h.read_int64("/state/stage_index") == 2);
      CHECK(h.read_int64("/pipeline/in_stage") == 1);
    }
    const json rec = json::parse(pipeline_record(D / "checkpoint.h5"));
    CHECK(rec["sweep"]["item"] == 1);
    REQUIRE(rec["sweep"]["rows"].size() == 1);
    CHECK(rec["sweep"]["rows"][0]["values"] == a_rows[0]["values"]);
    run(f, E, tmp.path, "--restart " + sparkdem::test::shell_quoted(D / "checkpoint.h5"));
    const json e = read_json(E / "summary.json");
    const json& rows = e["stages"][0]["sweep"]["rows"];
    REQUIRE(rows.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) CHECK(rows[k]["values"] == a_rows[k]["values"]);
    CHECK(rows[0]["directory"] == fs::absolute(D / "sweep_more/0").lexically_normal().string());  // run before the restart
    CHECK_FALSE(fs::exists(E / "sweep_more/0"));
    CHECK(read_json(E / "sweep_more/1/summary.json").contains("restarted_from"));
    CHECK(e["stages"][1]["final"] == a["stages"][3]["final"]);
    require_same_state(A / "sweep_more/2/final_state.h5", E / "sweep_more/2/final_state.h5");
    require_same_state(A / "final_state.h5", E / "final_state.h5");
  }
}

TEST_CASE("an ensemble of five seeds of a fill: rows, mean and spread", "[sweeps][scenario]") {
  ScratchDir tmp;
  const json scene = load_data("sweep_fill_ensemble.json");
  const fs::path f = write_scene(tmp.path, "ensemble.json", scene), A = tmp.path / "A", B = tmp.path / "B";
  run(f, A, tmp.path);
  const json sum = read_json(A / "summary.json");
  const json& sw = sum["stages"][0]["sweep"];
  const json& gen = scene["stages"][0]["generator"];
  CHECK(sw["kind"] == "seeds");
  REQUIRE(sw["rows"].size() == 5);
  for (std::size_t k = 0; k < 5; ++k) {
    const json& r = sw["rows"][k];
    INFO("seed " << r["seed"]);
    CHECK(r["seed"] == scene["stages"][0]["sweep"]["seeds"][k]);
    CHECK(r["status"] == "completed");
    // Every member is a valid packing: the fill's stop conditions hold.
    CHECK(r["until_reached"] == true);
    CHECK(r["values"]["packing.particles"] == 60);
    CHECK(std::abs(r["values"]["packing.packing_density"].get<double>() - gen["target_density"].get<double>()) <= 0.01);
    CHECK(r["values"]["kinetic_energy_per_mass"].get<double>() <= gen["ke_per_mass_below"].get<double>());
    CHECK(r["values"]["max_overlap_ratio"].get<double>() <= gen["max_overlap"].get<double>());
  }
  // Different seeds, different packings (the fill scales the radii to the target density, so
  // compare the settled states): kinetic energy and largest overlap differ pairwise.
  for (std::size_t i = 0; i < 5; ++i)
    for (std::size_t j = i + 1; j < 5; ++j)
      for (const char* c : {"kinetic_energy_per_mass", "packing.max_overlap_ratio"})
        CHECK(sw["rows"][i]["values"][c] != sw["rows"][j]["values"][c]);

  // Mean and sample standard deviation of every column, recomputed from the rows.
  const json& stats = sw["statistics"];
  REQUIRE(stats.size() == sw["columns"].size());
  REQUIRE(stats.size() > 20);
  for (const auto& col : sw["columns"]) {
    const std::string c = col.get<std::string>();
    INFO("column " << c);
    std::vector<double> x;
    for (const auto& r : sw["rows"])
      if (r["values"].value(c, json()).is_number()) x.push_back(r["values"][c].get<double>());
    CHECK(stats[c]["count"] == x.size());
    if (x.size() < 2) continue;
    double m = 0.0;
    for (double v : x) m += v;
    m /= static_cast<double>(x.size());
    double ss = 0.0;
    for (double v : x) ss += (v - m) * (v - m);
    const double sd = std::sqrt(ss / static_cast<double>(x.size() - 1));
    CHECK(std::abs(stats[c]["mean"].get<double>() - m) <= 1e-12 * std::abs(m));
    CHECK(std::abs(stats[c]["std"].get<double>() - sd) <= 1e-12 * std::abs(sd));
  }
  CHECK(stats["kinetic_energy_per_mass"]["std"].get<double>() > 0.0);
  // The table has one row per seed, with the same numbers.
  const auto csv = read_csv(A / "sweep_cook.csv");
  REQUIRE(csv.size() == 6);
  CHECK(csv[0][0] == "item");
  CHECK(csv[0][1] == "seed");
  CHECK(csv[0][2] == "status");
  for (std::size_t k = 0; k < 5; ++k)
    for (std::size_t c = 3; c < csv[0].size(); ++c) {
      const json& v = sw["rows"][k]["values"].at(csv[0][c]);
      if (v.is_number())
        CHECK(std::stod(csv[k + 1][c]) == v.get<double>());
      else
        CHECK(csv[k + 1][c] == "nan");
    }
  // The main state after the ensemble is the state before it: no particles.
  CHECK(sum["particles"] == 0);

  // Same seeds, same rows, bit for bit.
  run(f, B, tmp.path);
  CHECK(read_json(B / "summary.json")["stages"][0]["sweep"]["rows"].size() == 5);
  for (std::size_t k = 0; k < 5; ++k)
    CHECK(read_json(B / "summary.json")["stages"][0]["sweep"]["rows"][k]["values"] == sw["rows"][k]["values"]);
  // Member 2 is exactly a plain run whose scenario seed is its seed.
  json plain = scene;
  plain["seed"] = scene["stages"][0]["sweep"]["seeds"][2];
  plain["stages"][0].erase("sweep");
  const fs::path P = tmp.path / "plain";
  run(write_scene(tmp.path, "plain.json", plain), P, tmp.path);
  require_same_state(P / "final_state.h5", A / "sweep_cook/2/final_state.h5");
}

TEST_CASE("a sweep of the gravity on a free fall: v = g t in every row", "[sweeps][scenario]") {
  ScratchDir tmp;
  json scene = load_data("sweep_fall.json");
  const json g_values = {-2.0, -5.0, -9.81};
  json sweep_stage = scene["stages"][1];
  sweep_stage.erase("snapshots");
  sweep_stage["name"] = "g";
  sweep_stage["stop"]["steps"] = 200;
  sweep_stage["sweep"] = {
      {"parameter", "/modules/gravity/acceleration/2"}, {"values", g_values}, {"collect", {"max_speed", "kinetic_energy_per_mass", "step"}}};
  json after = scene["stages"][3];
  after.erase("modules");  // no gravity: the particles stay at rest unless a sweep item moved them
  after["stop"]["steps"] = 10;
  scene["stages"] = json::array({scene["stages"][0], sweep_stage, after});
  const fs::path A = tmp.path / "A";
  run(write_scene(tmp.path, "g.json", scene), A, tmp.path);
  const json sum = read_json(A / "summary.json");
  const json& sw = sum["stages"][1]["sweep"];
  CHECK(sw["kind"] == "parameter");
  CHECK(sw["parameter"] == "/modules/gravity/acceleration/2");
  CHECK(sw["columns"] == json({"max_speed", "kinetic_energy_per_mass", "step"}));
  REQUIRE(sw["rows"].size() == 3);
  const double t = 200 * kDt;
  for (std::size_t k = 0; k < 3; ++k) {
    const double g = g_values[k].get<double>();
    const json& r = sw["rows"][k];
    INFO("g = " << g);
    CHECK(r["value"] == g);
    CHECK(r["values"]["step"] == 200);
    CHECK(close_rel(r["values"]["max_speed"].get<double>(), std::abs(g) * t, 1e-12));
    CHECK(close_rel(r["values"]["kinetic_energy_per_mass"].get<double>(), 0.5 * g * g * t * t, 1e-12));
    // The item ran its substituted stage.
    const json res = read_json(A / r["directory"].get<std::string>() / "resolved.json");
    CHECK(res["stages"][0]["modules"]["gravity"]["acceleration"][2] == g);
  }
  const auto csv = read_csv(A / "sweep_g.csv");
  REQUIRE(csv.size() == 4);
  CHECK(csv[0] == std::vector<std::string>{"item", "value", "status", "max_speed", "kinetic_energy_per_mass", "step"});
  for (std::size_t k = 0; k < 3; ++k) CHECK(std::stod(csv[k + 1][1]) == g_values[k].get<double>());
  // The sweep is a branch: the last stage starts from the lattice at rest.
  CHECK(sum["stages"][2]["final"]["step"] == 10);
  CHECK(sum["stages"][2]["final"]["kinetic_energy"] == 0.0);

  // keep_item_states false: the same rows, no item final_state.h5; sweep_g/results.xdmf lists
  // each item's last frame (one time step per item), whose velocities are g t.
  scene["stages"][1]["sweep"]["keep_item_states"] = false;
  const fs::path B = tmp.path / "B";
  run(write_scene(tmp.path, "g_lean.json", scene), B, tmp.path);
  CHECK(read_csv(B / "sweep_g.csv") == csv);
  std::ifstream xdmf_in(B / "sweep_g" / "results.xdmf");
  const std::string xdmf{std::istreambuf_iterator<char>(xdmf_in), {}};
  for (std::size_t k = 0; k < 3; ++k) {
    const fs::path item = B / "sweep_g" / std::to_string(k);
    CHECK_FALSE(fs::exists(item / "final_state.h5"));
    CHECK(fs::exists(A / "sweep_g" / std::to_string(k) / "final_state.h5"));
    const std::string frame = std::to_string(k) + "/frames/frame_000000.h5";  // frame_every 0: the final frame only
    CHECK(xdmf.find("<Time Value=\"" + std::to_string(k) + "\"/>") != std::string::npos);
    REQUIRE(xdmf.find(frame + ":/particles/position") != std::string::npos);
    const auto v = sparkdem::io::H5File::open_read(B / "sweep_g" / frame).read_doubles("/particles/velocity");
    REQUIRE(!v.empty());
    for (std::size_t i = 2; i < v.size(); i += 3) CHECK(close_rel(std::abs(v[i]), std::abs(g_values[k].get<double>()) * t, 1e-12));
  }
}

TEST_CASE("sweep and snapshot configuration errors are all reported at once with their paths", "[sweeps][config_errors][scenario]") {
  json scene = load_data("sweep_fall.json");
  CHECK_NOTHROW(sparkdem::io::load_scenario(scene, registry(), SPARKDEM_SOURCE_DIR));
  const json more = scene["stages"][2];
  auto stage = [&](const std::string& name, const json& sweep) {
    json s = more;
    s["name"] = name;
    s["sweep"] = sweep;
    return s;
  };
  scene["stages"][1]["snapshots"].erase("column");  // `at` without its column
  scene["stages"][2]["sweep"]["snapshots_of"] = "fal";
  scene["stages"].push_back(stage("p1", {{"parameter", "/modules/gravty/acceleration/2"}, {"values", {1.0}}}));
  scene["stages"].push_back(stage("p2", {{"parameter", "/modules/gravity/accel"}, {"values", {1.0}}}));
  scene["stages"].push_back(stage("p3", {{"parameter", "modules"}, {"values", {1.0}}}));
  scene["stages"].push_back(stage("e1", {{"seeds", json::array()}}));
  scene["stages"].push_back(stage("e2", {{"parameter", "/dt"}, {"values", json::array()}}));
  scene["stages"].push_back(stage("two", {{"seeds", {1, 2}}, {"parameter", "/dt"}, {"values", {1e-5}}}));
  scene["stages"].push_back(stage("bad_value", {{"parameter", "/dt"}, {"values", {1e-5, -1.0, "x"}}}));
  scene["stages"].push_back(stage("c1", {{"snapshots_of", "fall"}, {"collect", {"time", "max_sped", "packing.particles"}}}));
  json typo = scene["stages"][3];
  typo["name"] = "t1";
  const json cal_ok = {{"parameter", "/dt"}, {"column", "max_speed"}, {"target", 1.0}, {"scan", {1e-5, 2e-5}}};
  json cal_bad = cal_ok;
  cal_bad["scan"] = {2e-5, 1e-5};
  cal_bad["column"] = "max_sped";
  cal_bad.erase("target");
  typo["snapshots"] = {{"column", "tme"}, {"at", {0.1}}};
  scene["stages"].push_back(typo);
  scene["stages"].push_back(stage("k1", {{"seeds", {1}}, {"calibrate", cal_ok}}));
  scene["stages"].push_back(stage("k2", {{"snapshots_of", "fall"}, {"calibrate", cal_bad}}));
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"/stages/1/snapshots/column", "`at` needs the time-series column"},
      {"/stages/2/sweep/snapshots_of", "no earlier stage named \"fal\" takes snapshots (did you mean \"fall\"?)"},
      {"/stages/4/sweep/parameter", "the stage has no /modules/gravty"},
      {"/stages/5/sweep/parameter", "names no parameter of the stage: unknown key \"accel\""},
      {"/stages/6/sweep/parameter", "is not a JSON pointer"},
      {"/stages/7/sweep/seeds", "expected a non-empty array of seeds"},
      {"/stages/8/sweep/values", "expected a non-empty array of values"},
      {"/stages/9/sweep", "give exactly one of snapshots_of, parameter, seeds; found parameter, seeds"},
      {"/stages/10/sweep/values/1", "value -1.0 for /dt: "},
      {"/stages/10/sweep/values/2", "value \"x\" for /dt: expected number"},
      {"/stages/11/sweep/collect/1", "\"max_sped\" is not a time-series column of this stage (did you mean \"max_speed\"?)"},
      {"/stages/11/sweep/collect/2", "no generator, so no packing report"},
      {"/stages/12/snapshots/column", "\"tme\" is not a time-series column of this stage (did you mean \"time\"?)"},
      {"/stages/13/sweep/calibrate", "calibrate goes with snapshots_of"},
      {"/stages/14/sweep/calibrate/scan", "expected at least two positive, increasing values"},
      {"/stages/14/sweep/calibrate/target", "required"},
      {"/stages/14/sweep/calibrate/column", "\"max_sped\" is not a time-series column"},
  };
  // In process: one ConfigError with every expected diagnostic and none at another path (a
  // rejected dt also leaves the stage without a step: "set dt or dt_fraction", at the same value).
  try {
    (void)sparkdem::io::load_scenario(scene, registry(), SPARKDEM_SOURCE_DIR);
    FAIL("load_scenario accepted an invalid scenario");
  } catch (const sparkdem::ConfigError& e) {
    INFO("diagnostics: " << e.what());
    for (const auto& d : e.diagnostics())
      CHECK(std::any_of(expected.begin(), expected.end(), [&](const auto& x) { return x.first == d.path; }));
    for (const auto& [path, fragment] : expected) {
      bool found = false;
      for (const auto& d : e.diagnostics()) found = found || (d.path == path && d.message.find(fragment) != std::string::npos);
      INFO("expected " << path << ": ..." << fragment);
      CHECK(found);
    }
  }
  // Through the executable: exit 2, every path on stderr, no output directory.
  ScratchDir tmp;
  const fs::path f = write_scene(tmp.path, "bad.json", scene);
  for (const std::string sub : {"check", "run"}) {
    const fs::path out = tmp.path / ("out_" + sub);
    const Cli r = cli(sub + " " + sparkdem::test::shell_quoted(f) + (sub == "run" ? " --quiet -o " + sparkdem::test::shell_quoted(out) : ""), tmp.path);
    INFO("sparkdem " << sub << " stderr:\n" << r.err);
    CHECK(r.code == 2);
    for (const auto& [path, fragment] : expected) CHECK(r.err.find(path + ": ") != std::string::npos);
    CHECK_FALSE(fs::exists(out));
  }
}

/// A chain of spheres (Holm branches in series): its resistance is inversely proportional to the
/// material conductivity, so calibrating the conductivity to a target resistance on one snapshot
/// has the closed form kappa* = kappa_1 R(kappa_1) / target, and the secant in
/// (ln value, ln column) of the search lands on it in one item.
TEST_CASE("a calibrating sweep over snapshots: scan, search to the closed form, validation on every snapshot", "[sweeps][scenario]") {
  ScratchDir tmp;
  json scene = load_data("sweep_calibrate_chain.json");
  const fs::path A = tmp.path / "A";
  run(write_scene(tmp.path, "cal.json", scene), A, tmp.path);
  const json sw = read_json(A / "summary.json")["stages"][2]["sweep"];
  const json& rows = sw["rows"];
  REQUIRE(rows.size() == 4 + 1 + 3);  // scan, one search item, three snapshots
  double r_at_1e6 = 0.0;
  for (std::size_t r = 0; r < 4; ++r) {
    CHECK(rows[r]["phase"] == "scan");
    CHECK(rows[r]["snapshot_index"] == 1);
    if (rows[r]["value"].get<double>() == 1e6) r_at_1e6 = rows[r]["values"]["electrical_resistance"].get<double>();
  }
  REQUIRE(r_at_1e6 > 0.0);
  // R is inverse in kappa: each scan value gives R = r_at_1e6 * 1e6 / value (1e-12).
  for (std::size_t r = 0; r < 4; ++r)
    CHECK(std::abs(rows[r]["values"]["electrical_resistance"].get<double>() / (r_at_1e6 * 1e6 / rows[r]["value"].get<double>()) - 1.0) <
          1e-12);
  const double expect = 1e6 * r_at_1e6 / 0.01;
  CHECK(rows[4]["phase"] == "search");
  const json& cal = sw["calibration"];
  CHECK(std::abs(cal["value"].get<double>() / expect - 1.0) < 1e-9);
  CHECK(std::abs(cal["achieved"].get<double>() / 0.01 - 1.0) < 1e-9);
  CHECK(cal["map"].size() == 5);
  for (std::size_t r = 5; r < 8; ++r) {
    CHECK(rows[r]["phase"] == "validate");
    CHECK(rows[r]["snapshot_index"] == static_cast<int>(r - 5));
    CHECK(rows[r]["value"].get<double>() == cal["value"].get<double>());
  }
  CHECK(std::abs(rows[6]["values"]["electrical_resistance"].get<double>() / 0.01 - 1.0) < 1e-9);

  // A target outside the scan's range is refused with both ends of the scan named.
  scene["stages"][2]["sweep"]["calibrate"]["target"] = 1e-15;
  const Cli r = cli("run " + sparkdem::test::shell_quoted(write_scene(tmp.path, "cal_out.json", scene)) + " -o " + sparkdem::test::shell_quoted(tmp.path / "B") + " --quiet", tmp.path);
  CHECK(r.code != 0);
  CHECK(r.err.find("is not bracketed by the scan") != std::string::npos);
  CHECK(read_csv(tmp.path / "B" / "sweep_fit.csv").size() == 5);  // header + the four scan rows
}

TEST_CASE("a module's own consistency errors carry their paths, all at once, without a cascade of unknown columns",
          "[config_errors][scenario]") {
  // ptc_strain checks its parameters in its constructor: every problem is reported with the
  // module's path, and the sweep's collect columns of that module are not reported as unknown
  // (the module was not built, so its columns are not known).
  json scene = load_data("cpc_small.json");
  CHECK_NOTHROW(sparkdem::io::load_scenario(scene, registry(), SPARKDEM_SOURCE_DIR));
  json& m = scene["stages"][0]["modules"]["ptc_strain"];
  m["boundary_faces"] = "z_lo,top";
  m["strain_histogram_edges"] = {0.01};
  m["strain_statistics"] = true;  // with the default bonded matrix
  scene["stages"][0]["sweep"] = {{"seeds", {1, 2}}, {"collect", {"ptc_strain_contacts", "ptc_strain_switching_strain"}}};
  scene["stages"].erase(1);  // a sweep is a branch: the settling stage after it would have no particles
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"/stages/0/modules/ptc_strain/boundary_faces", "found \"z_lo,top\""},
      {"/stages/0/modules/ptc_strain/strain_histogram_edges", "needs at least two edges"},
      {"/stages/0/modules/ptc_strain/strain_statistics", "needs matrix_model \"rkpm\""},
  };
  try {
    (void)sparkdem::io::load_scenario(scene, registry(), SPARKDEM_SOURCE_DIR);
    FAIL("load_scenario accepted an invalid scenario");
  } catch (const sparkdem::ConfigError& e) {
    INFO("diagnostics: " << e.what());
    CHECK(e.diagnostics().size() == expected.size());
    for (const auto& [path, fragment] : expected) {
      bool found = false;
      for (const auto& d : e.diagnostics()) found = found || (d.path == path && d.message.find(fragment) != std::string::npos);
      INFO("expected " << path << ": ..." << fragment);
      CHECK(found);
    }
  }
}

}  // namespace test_sweeps
