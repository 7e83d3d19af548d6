/// results.xdmf of a multi-stage run (tests/scenario/data/xdmf_stages.json) as ParaView reads it:
/// its temporal collection must hold one grid per time at strictly increasing times (ParaView's
/// XDMFReader merges the grids within 2.2e-16 s of the time it shows into one empty multiblock,
/// which showed 0 particles at the stage boundaries), each grid with the particles of its frame
/// file, and every frame file in frames/ referenced. The scene's stage boundaries give the three
/// kinds of coincident frames: a lattice frame and the next stage's first frame at t = 0, a
/// stage's last frame_every frame and its closing frame (one state: written once), and a stage's
/// first frame after deleting particles at the time of the previous stage's last frame.
/// (tools/check_xdmf_paraview.py opens the same scene's output in ParaView itself.)
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "io/hdf5/h5file.hpp"
#include "io/hdf5/results_writer.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_xdmf_frames {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

/// One grid of the temporal collection, as written in results.xdmf.
struct XdmfGrid {
  std::string name;
  double listed_time = 0.0;  ///< <Time Value>
  double true_time = 0.0;    ///< <Information Name="time">
  std::int64_t step = -1;    ///< <Information Name="step">
  std::string stage;         ///< <Information Name="stage">
  std::size_t elements = 0;  ///< Topology NumberOfElements
  struct Item {
    std::size_t rows, columns;
    std::string file, dataset;
  };
  std::vector<Item> items;              ///< every DataItem (geometry and attributes)
  std::vector<std::string> attributes;  ///< Attribute names
};

std::string read_text(const fs::path& f) {
  std::ifstream in(f);
  REQUIRE(in);
  return {std::istreambuf_iterator<char>(in), {}};
}

std::string capture(const std::string& text, const std::regex& re) {
  std::smatch m;
  REQUIRE(std::regex_search(text, m, re));
  return m[1];
}

/// The Uniform grids of results.xdmf, in file order.
std::vector<XdmfGrid> parse_grids(const std::string& xdmf) {
  static const std::regex grid(R"x(<Grid Name="([^"]+)" GridType="Uniform">([\s\S]*?)</Grid>)x");
  static const std::regex time_value(R"x(<Time Value="([^"]+)"/>)x"), info_time(R"x(<Information Name="time" Value="([^"]+)"/>)x"),
      info_step(R"x(<Information Name="step" Value="([^"]+)"/>)x"), info_stage(R"x(<Information Name="stage" Value="([^"]*)"/>)x"),
      elements(R"x(NumberOfElements="([0-9]+)")x"), attribute(R"x(<Attribute Name="([^"]+)")x"),
      item(R"x(<DataItem Dimensions="([0-9]+) ([0-9]+)"[^>]*>([^<:]+):([^<]+)</DataItem>)x");
  std::vector<XdmfGrid> out;
  for (auto it = std::sregex_iterator(xdmf.begin(), xdmf.end(), grid); it != std::sregex_iterator(); ++it) {
    const std::string body = (*it)[2];
    XdmfGrid g;
    g.name = (*it)[1];
    g.listed_time = std::stod(capture(body, time_value));
    g.true_time = std::stod(capture(body, info_time));
    g.step = std::stoll(capture(body, info_step));
    g.stage = capture(body, info_stage);
    g.elements = std::stoul(capture(body, elements));
    for (auto a = std::sregex_iterator(body.begin(), body.end(), attribute); a != std::sregex_iterator(); ++a)
      g.attributes.push_back((*a)[1]);
    for (auto d = std::sregex_iterator(body.begin(), body.end(), item); d != std::sregex_iterator(); ++d)
      g.items.push_back({std::stoul((*d)[1]), std::stoul((*d)[2]), (*d)[3], (*d)[4]});
    out.push_back(std::move(g));
  }
  return out;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("results.xdmf of a multi-stage run: one grid per time, strictly increasing, each with its frame's particles",
          "[xdmf][scenario]") {
  test::ScratchDir tmp("sparkdem_xdmf_frames");
  const fs::path out = tmp.path / "out";
  io::Scenario sc = io::load_scenario(test::load_data("xdmf_stages.json"), test::registry(), tmp.path);
  io::RunOptions opt;
  opt.outdir = out;
  opt.quiet = true;
  opt.threads = 1;
  const json summary = io::run_scenario(sc, opt);
  REQUIRE(summary["status"] == "completed");

  const std::string xdmf = read_text(out / "results.xdmf");
  const std::vector<XdmfGrid> grids = parse_grids(xdmf);
  // One temporal collection holding every grid, nothing else.
  CHECK(count(xdmf, "CollectionType=\"Temporal\"") == 1);
  CHECK(count(xdmf, "<Grid ") == grids.size() + 1);

  // One frame per (stage, step): the closing frames of settle (step 300 = its last frame_every
  // step), cut (500) and probe (no steps) are the state of the frame before them, written once.
  const std::vector<std::pair<std::string, std::int64_t>> expected{{"create", 0},   {"settle", 0},   {"settle", 100},
                                                                   {"settle", 200}, {"settle", 300}, {"cut", 300},
                                                                   {"cut", 400},    {"cut", 500},    {"probe", 500}};
  std::vector<std::pair<std::string, std::int64_t>> got;
  for (const XdmfGrid& g : grids) got.emplace_back(g.stage, g.step);
  CHECK(got == expected);
  REQUIRE(grids.size() == expected.size());

  // Times: strictly increasing, unique, at least ParaView's merge window (2.2e-16 s) apart.
  std::set<double> unique;
  std::size_t coincident = 0;
  for (std::size_t k = 0; k < grids.size(); ++k) {
    INFO("grid " << grids[k].name << ": listed t = " << grids[k].listed_time << " s, true t = " << grids[k].true_time << " s");
    unique.insert(grids[k].listed_time);
    if (k == 0) {
      CHECK(grids[k].listed_time == grids[k].true_time);
      continue;
    }
    CHECK(grids[k].listed_time > grids[k - 1].listed_time + 2.3e-16);
    if (grids[k].true_time == grids[k - 1].true_time) {
      // The first frame of a stage at the previous stage's last time: listed 1e-15 s later.
      ++coincident;
      CHECK(grids[k].stage != grids[k - 1].stage);
      CHECK(std::abs(grids[k].listed_time - grids[k - 1].listed_time - io::ResultsWriter::kXdmfTimeGap) <= 1e-17);
    } else {
      CHECK(grids[k].listed_time == grids[k].true_time);  // every other frame at its true time
    }
  }
  CHECK(unique.size() == grids.size());  // one grid per time
  CHECK(coincident == 3);                // create|settle at 0, settle|cut at 300, cut|probe at 500
  CHECK(grids[4].true_time == Approx(300 * 2e-5).epsilon(1e-12));

  // Each grid: its own frame file, whose /particles datasets have the rows and columns the grid
  // declares; the true time, step and stage are the frame file's.
  std::set<std::string> referenced;
  for (std::size_t k = 0; k < grids.size(); ++k) {
    const XdmfGrid& g = grids[k];
    INFO("grid " << g.name);
    REQUIRE(!g.items.empty());
    const std::string file = g.items.front().file;
    CHECK(file == io::ResultsWriter::frame_file(static_cast<int>(k)));
    CHECK(referenced.insert(file).second);
    const auto h5 = io::H5File::open_read(out / file);
    const auto position = h5.shape("/particles/position");
    REQUIRE(position.size() == 2);
    CHECK(position[1] == 3);
    CHECK(g.elements == position[0]);
    CHECK(position[0] > 0);
    for (const auto& item : g.items) {
      INFO("data item " << item.file << ":" << item.dataset);
      CHECK(item.file == file);
      const auto shape = h5.shape(item.dataset);
      REQUIRE(shape.size() == 2);
      CHECK(item.rows == shape[0]);
      CHECK(item.columns == shape[1]);
    }
    CHECK(h5.attribute_double("/", "time") == g.true_time);
    CHECK(h5.attribute_int64("/", "step") == g.step);
    CHECK(h5.attribute_string("/", "stage") == g.stage);
    for (const char* field : {"velocity", "omega", "force", "radius", "id", "material"})
      CHECK(std::count(g.attributes.begin(), g.attributes.end(), field) == 1);
  }
  // The deletion at the start of cut shows in its first grid (same time as settle's last).
  const json& cut = summary["stages"][2];
  REQUIRE(cut["name"] == "cut");
  const auto deleted = cut["deleted_particles"]["total"].get<std::size_t>();
  CHECK(deleted > 0);
  CHECK(grids[5].elements + deleted == grids[4].elements);
  CHECK(grids[8].elements == summary["particles"].get<std::size_t>());

  // Every frame file in frames/ is referenced (and results.h5 links each).
  std::set<std::string> on_disk;
  for (const auto& e : fs::directory_iterator(out / "frames")) on_disk.insert("frames/" + e.path().filename().string());
  CHECK(on_disk == referenced);
  CHECK(io::H5File::open_read(out / "results.h5").children("/frames").size() == grids.size());
}

}  // namespace test_xdmf_frames
