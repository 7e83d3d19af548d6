/// The electrical network's per-branch output in the frames (/networks/electrical): through a
/// scenario run in process. Invariants on a straight chain of spheres (branches in series):
/// every branch and every particle carries the electrode current, and the branch powers add up
/// to V I.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "io/hdf5/h5file.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/scratch.hpp"

namespace test_electrical_output {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
}  // namespace

TEST_CASE("electrical_network writes branch currents, conductances and powers to the frames", "[electrical][scenario]") {
  const json scene = json::parse(R"({
    "name": "chain_output", "materials": [{"name": "m", "density": 8000}],
    "contact": {"law": "hertz_mindlin", "params": {"youngs_modulus": 1e9}},
    "particle_sets": {"top": {"type": "top_layer", "thickness": 0.001},
                      "bottom": {"type": "bottom_layer", "thickness": 0.001}},
    "stages": [
      {"name": "chain", "type": "lattice",
       "generator": {"lo": [0, 0, 0], "hi": [0.0005, 0.0005, 0.0096], "spacing": 0.00199, "diameter": 0.002}},
      {"name": "measure", "type": "dynamics", "dt_fraction": 0.1, "sets": ["top", "bottom"],
       "modules": {"electrical_network": {"model": "holm", "conductivity": 1e6, "high": "top", "low": "bottom", "voltage": 0.5}},
       "stop": {"steps": 0}}
    ]})");
  sparkdem::test::ScratchDir tmp("sparkdem_elec_out");
  sparkdem::io::Scenario sc = sparkdem::io::load_scenario(scene, sparkdem::test::registry(), tmp.path);
  sparkdem::io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  const json summary = sparkdem::io::run_scenario(sc, opt);
  const double I = summary["stages"][1]["final"]["electrical_current"].get<double>();
  REQUIRE(I > 0.0);
  const auto f = sparkdem::io::H5File::open_read(opt.outdir / "frames/frame_000001.h5");
  const auto pairs = f.read_int64s("/networks/electrical/pairs");
  const auto current = f.read_doubles("/networks/electrical/current");
  const auto power = f.read_doubles("/networks/electrical/power");
  const auto g = f.read_doubles("/networks/electrical/conductance");
  const auto n = summary["stages"][1]["particles"].get<std::size_t>();
  REQUIRE(n >= 4);
  REQUIRE(current.size() == n - 1);  // n spheres in a row: n - 1 branches in series
  REQUIRE(pairs.size() == 2 * (n - 1));
  double P = 0.0;
  for (std::size_t e = 0; e < current.size(); ++e) {
    CHECK(std::abs(std::abs(current[e]) - I) <= 1e-12 * I);  // series: the same current everywhere
    CHECK(std::abs(power[e] - current[e] * current[e] / g[e]) <= 1e-12 * power[e]);
    P += power[e];
  }
  CHECK(std::abs(P - 0.5 * I) <= 1e-12 * P);  // sum I^2 R = V I
  // The current through each particle (the end ones take it from their electrode): I in series.
  const auto through = f.read_doubles("/particles/particle_current");
  REQUIRE(through.size() == n);
  for (double x : through) CHECK(std::abs(x - I) <= 1e-12 * I);
  // The frame borrows the module's held branch output and hands it back: the stage's final state,
  // written after the frame, checkpoints the same branches, bit for bit.
  const auto ck = sparkdem::io::H5File::open_read(opt.outdir / "final_state.h5");
  CHECK(ck.read_int64s("/modules/electrical_network/branch_pairs") == pairs);
  const auto held = ck.read_doubles("/modules/electrical_network/branch_values");
  REQUIRE(held.size() == 3 * current.size());
  for (std::size_t e = 0; e < current.size(); ++e) {
    CHECK(held[3 * e] == current[e]);
    CHECK(held[3 * e + 1] == g[e]);
    CHECK(held[3 * e + 2] == power[e]);
  }
}

}  // namespace test_electrical_output
