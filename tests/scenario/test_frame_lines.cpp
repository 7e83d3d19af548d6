/// The frames' line sets (issue 61): every drawn row's /nodes joins the two particles of the row.
/// Frames are not in id order, so for each row the ids at its two node rows in /particles/id must
/// equal the row's pair of ids (a wall end takes the other end's row). Checked at every frame of
/// runs that rebuild and sort their neighbour lists, delete particles, break bonds, solve an
/// electrical network, and restart; and results.xdmf lists one line grid per frame and set, with
/// the cells the frame's /nodes holds.
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <string>
#include <vector>

#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_frame_lines {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json run(const json& scene, const fs::path& out, const std::optional<fs::path>& restart = {}) {
  return test::run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data", out, restart);
}

/// Checks every drawn set of every frame in out/frames; returns the drawn rows per set name.
std::map<std::string, std::size_t> check_frames(const fs::path& out) {
  std::map<std::string, std::size_t> rows;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(out / "frames")) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  REQUIRE(!files.empty());
  for (const fs::path& f : files) {
    const auto h5 = io::H5File::open_read(f);
    const std::vector<double> id = h5.read_doubles("/particles/id");
    std::vector<std::string> groups{"/contacts", "/bonds"};
    if (h5.exists("/networks"))
      for (const std::string& n : h5.children("/networks")) groups.push_back("/networks/" + n);
    for (const std::string& g : groups) {
      if (!h5.exists(g + "/nodes")) continue;
      INFO(f.filename().string() << " " << g);
      const std::vector<std::int64_t> pairs = h5.read_int64s(g + "/pairs"), nodes = h5.read_int64s(g + "/nodes");
      REQUIRE(nodes.size() == pairs.size());
      for (std::size_t e = 0; e < pairs.size(); e += 2) {
        for (int end = 0; end < 2; ++end) {
          const std::int64_t node = nodes[e + end], want = pairs[e + end] >= 0 ? pairs[e + end] : pairs[e + 1 - end];
          REQUIRE(node >= 0);
          REQUIRE(static_cast<std::size_t>(node) < id.size());
          REQUIRE(static_cast<std::int64_t>(id[node]) == want);
        }
      }
      rows[g] += pairs.size() / 2;
    }
  }
  // results.xdmf: per set one temporal collection with one grid per frame, of the cells /nodes holds.
  std::ifstream in(out / "results.xdmf");
  const std::string xdmf{std::istreambuf_iterator<char>(in), {}};
  static const std::regex line_grid(R"x(<Grid Name="([^"]+)_([0-9]{6})" GridType="Uniform">\s*<Time[^>]*>\s*<Topology TopologyType="Polyline" NumberOfElements="([0-9]+)")x");
  std::map<std::string, std::size_t> grids;
  for (auto it = std::sregex_iterator(xdmf.begin(), xdmf.end(), line_grid); it != std::sregex_iterator(); ++it) {
    const std::string name = (*it)[1];
    const int frame = std::stoi((*it)[2]);
    const std::size_t cells = std::stoul((*it)[3]);
    ++grids[name];
    const auto h5 = io::H5File::open_read(out / "frames" / files.at(frame).filename());
    const std::string group = name == "contacts" || name == "bonds" ? "/" + name : "/networks/" + name;
    INFO("xdmf grid " << name << " of frame " << frame);
    CHECK(cells == (h5.exists(group + "/nodes") ? h5.shape(group + "/nodes").at(0) : 0));
  }
  for (const auto& [name, n] : grids) CHECK(n == files.size());
  return rows;
}

}  // namespace

TEST_CASE("frame lines: each cell joins its row's two particles through deletions, rebuilds and sorts", "[xdmf][network][scenario]") {
  test::ScratchDir tmp("sparkdem_frame_lines_delete");
  // gen_relax_small (300 particles relaxed in a 10 mm box), a slot cut from it, then a fall
  // under gravity with frames every 50 steps (neighbour rebuilds and spatial sorts in between).
  json scene = test::load_data("gen_relax_small.json");
  scene["particle_sets"] = {{"slot", {{"type", "box"}, {"lo", {-1, -1, 0.004}}, {"hi", {0.003, 1, 0.006}}}}};
  scene["stages"].push_back({{"name", "cut"}, {"type", "dynamics"}, {"dt_fraction", 0.3}, {"delete_sets", {"slot"}}, {"stop", {{"steps", 0}}}});
  scene["stages"].push_back({{"name", "fall"},
                             {"type", "dynamics"},
                             {"dt_fraction", 0.3},
                             {"sort_every_rebuilds", 1},
                             {"modules", {{"gravity", {{"acceleration", {0, 0, -9.81}}}}}},
                             {"stop", {{"steps", 400}}},
                             {"output", {{"frame_every", 50}}}});
  for (json& st : scene["stages"]) st["output"]["network"] = "contacts";
  const json summary = run(scene, tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  const auto rows = check_frames(tmp.path / "out");
  CHECK(rows.at("/contacts") > 100);
  CHECK(rows.count("/bonds") == 0);
}

TEST_CASE("frame lines: bonds breaking and electrical branches (walls included), and a restarted run", "[xdmf][network][restart][scenario]") {
  test::ScratchDir tmp("sparkdem_frame_lines_torsion");
  json scene = test::load_data("torsion_small.json");
  scene["stages"][1]["output"]["frame_every"] = 20;
  scene["stages"][1]["output"]["checkpoint_every"] = 40;
  const json summary = run(scene, tmp.path / "out");
  REQUIRE(summary["status"] == "completed");
  const auto rows = check_frames(tmp.path / "out");
  CHECK(rows.at("/bonds") > 1000);
  CHECK(rows.at("/networks/electrical") > 100);
  CHECK(rows.count("/contacts") == 1);
  // Broken bonds are drawn with the step they broke at; intact ones with -1.
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(tmp.path / "out" / "frames")) files.push_back(e.path());
  const auto last = io::H5File::open_read(*std::max_element(files.begin(), files.end()));
  const std::vector<double> broken = last.read_doubles("/bonds/broken"), step = last.read_doubles("/bonds/broken_step");
  std::size_t n_broken = 0;
  for (std::size_t r = 0; r < broken.size(); ++r) {
    n_broken += broken[r] == 1.0;
    CHECK((broken[r] == 1.0 ? step[r] >= 0.0 : step[r] == -1.0));
  }
  CHECK(n_broken == summary["stages"][1]["bonds"]["broken"].get<std::size_t>());
  const fs::path cp = tmp.path / "out" / "checkpoint.h5";
  REQUIRE(fs::exists(cp));
  const json again = run(scene, tmp.path / "restarted", cp);
  REQUIRE(again["status"] == "completed");
  check_frames(tmp.path / "restarted");
}

}  // namespace test_frame_lines
