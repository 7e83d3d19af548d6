/// Thick-plate validation of seed 001 (§3.2; physics note §7.2): configs/plate_source.json (a
/// 30 x 30 x 2.5 mm plate, ground on the edge face y = 0, +1 V on a central source of radius
/// 3 mm through the depth) against the finite-difference reference of
/// tests/support/fd_laplace2d.hpp, at P1 = (15, 6) mm (halfway between the ground and the
/// source's edge), P1c = (15, 7.5) mm (halfway to the source centre) and P2 = (0, 30) mm (the
/// top-left corner). DEM potential at a point: tests/support/plate_probe.hpp. The N = 5000,
/// 10000, 20000 runs of the seed are the benchmark benchmarks/plate_source.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/fd_laplace2d.hpp"
#include "support/plate_probe.hpp"
#include "support/scratch.hpp"

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

/// The FD reference at the control points: Richardson from three grids (nx cells across 30 mm).
std::map<std::string, fd::Richardson> fd_reference(int n0) {
  const fd::Problem pb = fd::plate_problem();
  const auto points = plate::control_points();
  std::map<std::string, std::vector<double>> v;
  for (int n : {n0, 2 * n0, 4 * n0}) {
    const fd::Solution s = fd::solve(pb, n);
    for (const auto& p : points) v[p.name].push_back(s.at(p.x, p.y));
  }
  std::map<std::string, fd::Richardson> out;
  for (const auto& p : points) out[p.name] = fd::richardson(v[p.name][0], v[p.name][1], v[p.name][2]);
  return out;
}

/// Run configs/plate_source.json with N particles and the fill stage's stop time changed; the
/// DEM potential at each control point (k = 24 probe) and the summary.
std::map<std::string, double> run_plate(std::int64_t particles, double fill_time, json& summary) {
  json scene = io::read_json_file(fs::path(SPARKDEM_SOURCE_DIR) / "configs/plate_source.json");
  scene["stages"][0]["generator"]["particles"] = particles;
  scene["stages"][0]["stop"]["time"] = fill_time;
  test::ScratchDir tmp("sparkdem_plate");
  io::Scenario sc = io::load_scenario(scene, test::registry(), tmp.path);
  io::RunOptions opt;
  opt.outdir = tmp.path / "out";
  opt.quiet = true;
  opt.threads = 1;
  summary = io::run_scenario(sc, opt);
  const plate::Frame fr = plate::read_last_frame(opt.outdir);
  std::map<std::string, double> phi;
  for (const auto& p : plate::control_points()) phi[p.name] = plate::probe_line(fr.position, fr.phi, p.x, p.y).value;
  return phi;
}
}  // namespace

TEST_CASE("plate FD reference: control-point values converge at second order", "[plate][fd]") {
  // Grids h = 30/60, 30/120, 30/240 mm (the benchmark goes to 30/960 mm). Measured:
  // P1 0.411203, 0.411142, 0.411128 (order 2.1); P2 0.820772, 0.820808, 0.820819 (order 1.8);
  // extrapolated P1 = 0.41112, P2 = 0.82082, within 1e-5 of the 30/480-30/960 mm values.
  // Checked: observed orders in [1.6, 2.4], bands below 2e-5, and the maximum principle
  // 0 < phi < 1 at the points.
  const auto ref = fd_reference(60);
  for (const auto& [name, r] : ref) {
    INFO(name << ": order " << r.observed_order << ", value " << r.extrapolated << " +- " << r.band);
    CHECK(r.observed_order > 1.6);
    CHECK(r.observed_order < 2.4);
    CHECK(r.band < 2e-5);
    CHECK(r.extrapolated > 0.0);
    CHECK(r.extrapolated < 1.0);
  }
  CHECK(ref.at("P1").extrapolated < ref.at("P1c").extrapolated);  // nearer the source: higher
  CHECK(ref.at("P1c").extrapolated < ref.at("P2").extrapolated);  // the far corner is the least drained
}

TEST_CASE("plate with a central source: DEM potentials at P1 and P2 against the FD reference (N = 2000)", "[plate][scenario][electrical]") {
  // A small, quickly packed plate: N = 2000 (mean radius ~0.5 mm, about 2.5 diameters through the
  // depth) and a fill stopped at 0.03 s (growth 0.02 s + 0.01 s of settling; ~13 s on one
  // loaded core) instead of 0.2 s. Measured errors (seed 1): P1 +7.5 %, P1c +9.0 %, P2 +1.9 %.
  // This small, loosely settled plate has few ground particles (32 touch the wall y = 0) and
  // potentials ride high; the converged-packing runs (benchmark) give P1 -5.9 %, P2 -0.9 % at
  // N = 5000. Tolerances: 12 % at P1 and P1c, 4 % at P2 (margin over the measured errors for
  // other platforms' rounding of the packing); they check the chain (fill, cylinder source set,
  // transmission_surface network, probe), not the seed's accuracy claim, which is the benchmark's.
  json summary;
  const auto phi = run_plate(2000, 0.03, summary);
  const auto ref = fd_reference(60);
  const json& st = summary["stages"][1];
  CHECK(st["particle_sets"]["source"].get<int>() > 30);
  CHECK(st["particle_sets"]["ground"].get<int>() > 10);
  const std::map<std::string, double> tol = {{"P1", 0.12}, {"P1c", 0.12}, {"P2", 0.04}};
  for (const auto& [name, t] : tol) {
    const double err = (phi.at(name) - ref.at(name).extrapolated) / ref.at(name).extrapolated;
    INFO(name << ": DEM " << phi.at(name) << ", FD " << ref.at(name).extrapolated << ", error " << 100 * err << " %");
    CHECK(std::abs(err) < t);
  }
}

TEST_CASE("plate with a central source, N = 5000 as configured: DEM against the FD reference", "[plate][scenario][electrical][slow]") {
  // configs/plate_source.json unchanged (fill to 0.2 s; ~4 min on one core). Measured (seed 1):
  // P1 -5.9 %, P1c -5.8 %, P2 -0.9 %. Most of the P1 error is the electrodes sitting at particle
  // centres: the ground nodes at y ~ r (mean 0.39 mm), the outermost source nodes inside r = 3 mm;
  // the FD solution with the ground moved to y = 0.4 mm and the source radius 2.8 mm gives
  // P1 = 0.386 (DEM 0.387; `bench_plate --sensitivity`). The packing's randomness matters as much:
  // seeds 2 and 3 give P1 -4.2 % and -9.9 % (P2 -1.9 %, -2.1 %; benchmarks/plate_source). This
  // test runs seed 1 (deterministic on one thread). Tolerances: 8 % at P1 and P1c, 3 % at P2.
  json summary;
  const auto phi = run_plate(5000, 0.2, summary);
  const auto ref = fd_reference(60);
  const std::map<std::string, double> tol = {{"P1", 0.08}, {"P1c", 0.08}, {"P2", 0.03}};
  for (const auto& [name, t] : tol) {
    const double err = (phi.at(name) - ref.at(name).extrapolated) / ref.at(name).extrapolated;
    INFO(name << ": DEM " << phi.at(name) << ", FD " << ref.at(name).extrapolated << ", error " << 100 * err << " %");
    CHECK(std::abs(err) < t);
  }
}
