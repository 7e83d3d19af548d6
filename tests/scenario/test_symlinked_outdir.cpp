/// An output directory reached through a symbolic link and "..", and the advice after a failed
/// run (issue 34 item 5), through the `sparkdem` executable and the pipeline API.
///
/// `-o LINK/../out` with LINK -> real/sub: the OS takes ".." after the link, so the directory is
/// real/out; a lexical normalisation gives "out" beside LINK, which does not exist (the bug: exit 4
/// at the first sweep stage, opening sweep_<stage>/input_state.h5.tmp there).
///
/// Invariants under test:
///  - every output (summary, snapshots, the sweep's input state, table and item directories) is at
///    the physical path real/out and nothing appears beside LINK; the sweep table is byte for byte
///    the table of the same run into a plain directory (and its values are the free-fall closed
///    form v = g t); the summary lists the input state and item directories inside real/out;
///  - a checkpoint inside a sweep item, restarted with `--restart LINK/../ck/checkpoint.h5` into
///    another LINK/../ path, ends with the rows of the uninterrupted run; the row run before the
///    restart names its item directory by its physical path;
///  - a run that fails after a stage completed names final_state.h5 and a command that continues
///    from it, and that command, run as printed, completes with the results of the uninterrupted
///    run; a run that failed before any stage completed gives no such advice.
#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/scratch.hpp"

namespace test_symlinked_outdir {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using sparkdem::test::load_data;
using sparkdem::test::write_scene;


std::string read_text(const fs::path& f) {
  std::ifstream in(f, std::ios::binary);
  REQUIRE(in);
  return {std::istreambuf_iterator<char>(in), {}};
}

json read_json(const fs::path& f) { return json::parse(read_text(f)); }

struct Cli {
  int code = -1;
  std::string err;
};

/// `command` (a shell command line) on one thread; stdout discarded, stderr kept.
Cli shell(const std::string& command, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=1 " + command + " > /dev/null 2> " + sparkdem::test::shell_quoted(err);
  const int rc = std::system(cmd.c_str());
  Cli r;
  if (rc != -1 && WIFEXITED(rc)) r.code = WEXITSTATUS(rc);
  r.err = read_text(err);
  return r;
}

Cli sparkdem_run(const fs::path& scene, const std::string& out, const fs::path& dir, const std::string& extra = "") {
  return shell(sparkdem::test::shell_quoted(SPARKDEM_BINARY) + " run " + sparkdem::test::shell_quoted(scene) + " -o " + sparkdem::test::shell_quoted(out) + " --quiet " + extra, dir);
}

/// Rows of a CSV file (no quoted cells).
std::vector<std::vector<std::string>> read_csv(const fs::path& file) {
  std::vector<std::vector<std::string>> rows;
  std::stringstream in(read_text(file));
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    rows.push_back(cells);
  }
  return rows;
}

/// The cells of `rows` from column `from` on (the values, without the item's keys).
std::vector<std::vector<std::string>> columns_from(const std::vector<std::vector<std::string>>& rows, std::size_t from) {
  std::vector<std::vector<std::string>> out;
  for (const auto& r : rows) out.emplace_back(r.begin() + static_cast<std::ptrdiff_t>(std::min(from, r.size())), r.end());
  return out;
}

/// tmp/real/sub, the link tmp/LINK -> tmp/real/sub, and the scene sweep_fall.json (8 spheres
/// falling freely: `create`, `fall` with three snapshots, `more` a sweep over them, `after`).
struct Linked : sparkdem::test::ScratchDir {
  fs::path real, link, scene;
  json fall = load_data("sweep_fall.json");
  Linked() : sparkdem::test::ScratchDir("sparkdem_symlinked_outdir") {
    real = path / "real";
    fs::create_directories(real / "sub");
    link = path / "LINK";
    fs::create_directory_symlink(real / "sub", link);
    scene = write_scene(path, "fall.json", fall);
  }
  /// LINK/../name as given on the command line, and where the OS puts it.
  std::string through_link(const std::string& name) const { return (link / ".." / name).string(); }
  fs::path physical(const std::string& name) const { return fs::canonical(real) / name; }
};

/// The uninterrupted run of sweep_fall.json into tmp/plain.
fs::path plain_run(const Linked& t) {
  const fs::path plain = t.path / "plain";
  const Cli r = sparkdem_run(t.scene, plain.string(), t.path);
  INFO("stderr:\n" << r.err);
  REQUIRE(r.code == 0);
  return plain;
}

constexpr double kDt = 1e-4, kG = 9.81;

}  // namespace

TEST_CASE("an output directory LINK/../out is written at its physical path", "[sweeps][scenario][restart]") {
  Linked t;
  REQUIRE(fs::path(t.through_link("out")).lexically_normal() == t.path / "out");  // what a lexical path would say
  const fs::path plain = plain_run(t);
  const json p = read_json(plain / "summary.json");

  SECTION("sparkdem run -o LINK/../out") {
    const Cli r = sparkdem_run(t.scene, t.through_link("out"), t.path);
    INFO("stderr:\n" << r.err);
    REQUIRE(r.code == 0);
    const fs::path out = t.physical("out");
    CHECK_FALSE(fs::exists(t.path / "out"));  // nothing beside LINK
    REQUIRE(fs::exists(out / "summary.json"));
    const json s = read_json(out / "summary.json");
    CHECK(s["status"] == "completed");

    // The sweep table: byte for byte the plain run's, 3 rows of the free fall v = g t.
    CHECK(read_text(out / "sweep_more.csv") == read_text(plain / "sweep_more.csv"));
    const auto csv = read_csv(out / "sweep_more.csv");
    REQUIRE(csv.size() == 4);
    REQUIRE(csv[0].size() == 10);
    for (std::size_t k = 1; k < csv.size(); ++k) {
      INFO("row " << k);
      CHECK(csv[k][5] == "completed");
      for (std::size_t c = 6; c < 10; ++c) CHECK(std::isfinite(std::stod(csv[k][c])));
      const double t1 = std::stod(csv[k][7]);
      CHECK(std::abs(std::stod(csv[k][9]) - kG * t1) <= 1e-10 * kG * t1);  // max_speed
      CHECK(std::abs(t1 - (std::stod(csv[k][3]) + 100 * kDt)) <= 1e-12);   // 100 steps after the snapshot
    }

    // Every file the summary names lies in the physical directory.
    const json& sw = s["stages"][2]["sweep"];
    CHECK(sw["input_state"] == "sweep_more/input_state.h5");
    CHECK(fs::exists(out / "sweep_more/input_state.h5"));
    REQUIRE(sw["rows"].size() == 3);
    for (std::size_t k = 0; k < 3; ++k) {
      CHECK(sw["rows"][k]["directory"] == "sweep_more/" + std::to_string(k));
      CHECK(fs::exists(out / "sweep_more" / std::to_string(k) / "final_state.h5"));
      CHECK(s["stages"][1]["snapshots"]["taken"][k]["file"] == "snapshots/fall_" + std::to_string(k) + ".h5");
      CHECK(fs::exists(out / "snapshots" / ("fall_" + std::to_string(k) + ".h5")));
    }
    CHECK(sw["rows"] == p["stages"][2]["sweep"]["rows"]);
    CHECK(s["stages"][3]["final"] == p["stages"][3]["final"]);  // the branch: `after` as in the plain run
    CHECK(fs::exists(out / "final_state.h5"));
  }

  SECTION("the pipeline API with outdir LINK/../api") {
    const json s = sparkdem::test::run_scene(t.fall, t.path, t.through_link("api"));
    CHECK(s["status"] == "completed");
    CHECK_FALSE(fs::exists(t.path / "api"));
    CHECK(read_text(t.physical("api") / "sweep_more.csv") == read_text(plain / "sweep_more.csv"));
  }

  SECTION("a checkpoint inside a sweep item, restarted through the link") {
    // Items run global steps 50-150, 120-220 and 240-340: step 200 lies in item 1 only.
    json ck = t.fall;
    ck["stages"][2]["output"]["checkpoint_every"] = 200;
    const fs::path f = write_scene(t.path, "ck.json", ck);
    const Cli a = sparkdem_run(f, t.through_link("ck"), t.path);
    INFO("first run, stderr:\n" << a.err);
    REQUIRE(a.code == 0);
    REQUIRE(fs::exists(t.physical("ck") / "checkpoint.h5"));
    const Cli b = sparkdem_run(f, t.through_link("ck2"), t.path, "--restart " + sparkdem::test::shell_quoted(t.through_link("ck") + "/checkpoint.h5"));
    INFO("restart, stderr:\n" << b.err);
    REQUIRE(b.code == 0);
    CHECK_FALSE(fs::exists(t.path / "ck2"));
    const json e = read_json(t.physical("ck2") / "summary.json");
    const json& rows = e["stages"][0]["sweep"]["rows"];
    REQUIRE(rows.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) CHECK(rows[k]["values"] == p["stages"][2]["sweep"]["rows"][k]["values"]);
    // The item run before the restart: named by its physical directory, which holds its outputs.
    CHECK(rows[0]["directory"] == (t.physical("ck") / "sweep_more/0").string());
    CHECK(fs::exists(t.physical("ck") / "sweep_more/0/final_state.h5"));
    CHECK(rows[1]["directory"] == "sweep_more/1");
    CHECK(e["stages"][1]["final"] == p["stages"][3]["final"]);
    // Values and status as in the plain table (the snapshot column names B's files by path).
    CHECK(columns_from(read_csv(t.physical("ck2") / "sweep_more.csv"), 5) == columns_from(read_csv(plain / "sweep_more.csv"), 5));
  }
}

namespace {

/// The command line the advice after a failure gives: the indented line after "To continue".
std::string continue_command(const std::string& err) {
  std::stringstream in(err);
  bool next = false;
  for (std::string line; std::getline(in, line);) {
    if (next && line.rfind("  ", 0) == 0) return line.substr(2);
    next = line.find("To continue the run from it") != std::string::npos;
  }
  return {};
}

/// The continued run (the command of the advice, run as printed into OUT_continued) ends as the
/// plain run: the sweep's rows and the stage after it.
void check_continued(const std::string& command, const fs::path& continued, const json& p, const fs::path& dir) {
  const Cli c = shell(command, dir);
  INFO("continued: " << command << " -> " << c.code << "; stderr:\n" << c.err);
  REQUIRE(c.code == 0);
  const json s = read_json(continued / "summary.json");
  CHECK(s.contains("restarted_from"));
  REQUIRE(s["stages"].size() == 2);  // `more` and `after`
  const json& rows = s["stages"][0]["sweep"]["rows"];
  REQUIRE(rows.size() == 3);
  for (std::size_t k = 0; k < 3; ++k) CHECK(rows[k]["values"] == p["stages"][2]["sweep"]["rows"][k]["values"]);
  CHECK(s["stages"][1]["final"] == p["stages"][3]["final"]);
}

}  // namespace

TEST_CASE("a run failing after a completed stage says how to continue, and that command works", "[scenario][restart]") {
  Linked t;
  const json p = read_json(plain_run(t) / "summary.json");

  SECTION("the sweep's input state cannot be written (set-up failure, exit 4), output through the link") {
    const fs::path out = t.physical("fail");
    fs::create_directories(out / "sweep_more/input_state.h5.tmp/blocker");  // a directory where the file goes
    const Cli r = sparkdem_run(t.scene, t.through_link("fail"), t.path);
    INFO("stderr:\n" << r.err);
    REQUIRE(r.code == 4);
    CHECK(r.err.find("input_state.h5") != std::string::npos);
    CHECK(r.err.find("stage 'fall' (2 of 4) was the last stage to complete; its end state is " + (out / "final_state.h5").string()) !=
          std::string::npos);
    CHECK(r.err.find("with stage 'more' (3 of 4)") != std::string::npos);
    const std::string command = continue_command(r.err);
    REQUIRE_FALSE(command.empty());
    CHECK(command.find("--restart " + (out / "final_state.h5").string()) != std::string::npos);
    CHECK(command.find("-o " + out.string() + "_continued") != std::string::npos);
    check_continued(command, t.physical("fail_continued"), p, t.path);
  }

  SECTION("a required stop condition not met (physics failure, exit 3)") {
    json until = t.fall;
    until["stages"][1]["until"] = {{"max_speed", {{"above", 1000.0}}}};
    until["stages"][1]["stop"]["require_until"] = true;
    const fs::path f = write_scene(t.path, "until.json", until), out = t.path / "until";
    const Cli r = sparkdem_run(f, out.string(), t.path);
    INFO("stderr:\n" << r.err);
    REQUIRE(r.code == 3);
    CHECK(r.err.find("stage 'fall' (2 of 4) ended at its hard stop with its required 'until' conditions unmet") != std::string::npos);
    const std::string command = continue_command(r.err);
    REQUIRE_FALSE(command.empty());
    CHECK(command.find("--restart " + (fs::canonical(out) / "final_state.h5").string()) != std::string::npos);
    check_continued(command, fs::canonical(t.path) / "until_continued", p, t.path);
  }

  SECTION("no stage completed: no advice") {
    const fs::path f = write_scene(t.path, "ensemble.json", load_data("sweep_fill_ensemble.json")), out = t.path / "ens";
    fs::create_directories(out / "sweep_cook/input_state.h5.tmp/blocker");
    const Cli r = sparkdem_run(f, out.string(), t.path);
    INFO("stderr:\n" << r.err);
    CHECK(r.code == 4);
    CHECK(r.err.find("--restart") == std::string::npos);
    CHECK(continue_command(r.err).empty());
  }
}

}  // namespace test_symlinked_outdir
