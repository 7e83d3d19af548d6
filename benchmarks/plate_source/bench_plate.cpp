/// Thick-plate validation of seed 001 (§3.2): the finite-difference reference and the DEM
/// potentials at the control points. The validation ledger's case seed001/plate
/// (tools/validate.py; benchmarks/validation/) runs it on each run directory after the DEM run:
///
///   bench_plate [--csv results.csv] [--fd-csv fd_convergence.csv] [--fd-grids "120 240 480 960"]
///               [--k 24] [--sensitivity] [RUN_DIR...]
///
/// Each RUN_DIR holds scene.json (the scenario as run) and out/ (its output directory); validate.py's
/// run directories (<workdir>/<tier>/seed001_plate/N<n>_seed<s>/) hold both, and their wall and CPU
/// time in scenario.meta.json. The table's run_time_s and cpu_time_s columns read the files
/// wall_time_s and cpu_time_s of the runs made before validate.py: NaN for validate.py's directories.
/// Without RUN_DIR only the reference is computed (--fd-csv writes its grid convergence table,
/// e.g. benchmarks/plate_source/fd_convergence.csv). The reference is the 2-D Laplace problem of
/// the plate (tests/support/fd_laplace2d.hpp) solved on the listed grids (nx cells
/// across 30 mm, each twice the previous), extrapolated by Richardson from the three finest.
/// The DEM potential at a control point is the linear least-squares fit over the k particles
/// nearest the control line (tests/support/plate_probe.hpp).
///
/// Diagnostics: per run, the mean height of the ground particles' centres and the largest
/// distance of a source particle's centre from the source axis (the DEM electrodes sit at
/// particle centres, not on the continuum boundary); with --sensitivity, the FD values at the
/// control points with the ground line moved to y0 and the source radius changed to a (grid
/// h = 0.1 mm, no extrapolation), to size the effect of where the electrodes sit.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support/fd_laplace2d.hpp"
#include "support/plate_probe.hpp"

namespace {
using nlohmann::json;
namespace fs = std::filesystem;
using namespace sparkdem;

struct Reference {
  double value, band, order;
};

json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw std::runtime_error("cannot read " + p.string());
  return json::parse(in);
}
}  // namespace

int main(int argc, char** argv) {
  try {
    std::string csv, fdcsv;
    std::vector<int> grids = {120, 240, 480, 960};
    std::size_t k = 24;
    bool sensitivity = false;
    std::vector<fs::path> runs;
    for (int a = 1; a < argc; ++a) {
      const std::string s = argv[a];
      if (s == "--csv" && a + 1 < argc)
        csv = argv[++a];
      else if (s == "--fd-csv" && a + 1 < argc)
        fdcsv = argv[++a];
      else if (s == "--k" && a + 1 < argc)
        k = std::stoul(argv[++a]);
      else if (s == "--sensitivity")
        sensitivity = true;
      else if (s == "--fd-grids" && a + 1 < argc) {
        grids.clear();
        std::istringstream in(argv[++a]);
        for (int n; in >> n;) grids.push_back(n);
      } else
        runs.emplace_back(s);
    }
    if (grids.size() < 3) throw std::runtime_error("--fd-grids needs at least three grids");
    for (std::size_t g = 1; g < grids.size(); ++g)
      if (grids[g] != 2 * grids[g - 1]) throw std::runtime_error("--fd-grids: each grid must be twice the previous");

    // ---- finite-difference reference: grid convergence and Richardson extrapolation
    const fd::Problem pb = fd::plate_problem();
    const auto points = plate::control_points();
    std::vector<std::vector<double>> vals(points.size());
    std::ostringstream fdtab;
    fdtab << "nx,h_m,unknowns,solve_time_s";
    for (const auto& p : points) fdtab << ",phi_" << p.name;
    fdtab << "\n";
    for (int n : grids) {
      const auto t0 = std::chrono::steady_clock::now();
      const fd::Solution sol = fd::solve(pb, n);
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      char line[256];
      std::snprintf(line, sizeof line, "%d,%.6e,%d,%.3f", n, sol.h, sol.unknowns, t);
      fdtab << line;
      for (std::size_t c = 0; c < points.size(); ++c) {
        vals[c].push_back(sol.at(points[c].x, points[c].y));
        std::snprintf(line, sizeof line, ",%.9f", vals[c].back());
        fdtab << line;
      }
      fdtab << "\n";
      std::cerr << "fd grid " << n << " done in " << t << " s\n";
    }
    std::map<std::string, Reference> ref;
    for (std::size_t c = 0; c < points.size(); ++c) {
      const auto& v = vals[c];
      const std::size_t m = v.size();
      const fd::Richardson r = fd::richardson(v[m - 3], v[m - 2], v[m - 1]);
      ref[points[c].name] = {r.extrapolated, r.band, r.observed_order};
      char line[256];
      std::snprintf(line, sizeof line, "# %s: Richardson (grids %d, %d, %d): observed order %.3f, reference %.6f +- %.1e\n", points[c].name,
                    grids[grids.size() - 3], grids[grids.size() - 2], grids.back(), r.observed_order, r.extrapolated, r.band);
      fdtab << line;
    }
    std::cout << fdtab.str();
    if (!fdcsv.empty()) std::ofstream(fdcsv) << fdtab.str();

    if (sensitivity) {
      std::cout << "# sensitivity (FD, h = 0.1 mm): ground line y0 [mm], source radius a [mm], phi at P1, P1c, P2\n";
      for (double y0 : {0.0, 0.2e-3, 0.3e-3, 0.4e-3})
        for (double a : {2.6e-3, 2.8e-3, 3.0e-3, 3.2e-3}) {
          fd::Problem p = fd::plate_problem();
          p.ly = 0.03 - y0;  // the plate above the ground line, in coordinates y' = y - y0
          p.cy = 0.015 - y0;
          p.radius = a;
          const fd::Solution s = fd::solve(p, 300);
          std::printf("# y0 %.1f a %.1f: %.5f %.5f %.5f\n", 1e3 * y0, 1e3 * a, s.at(0.015, 0.006 - y0), s.at(0.015, 0.0075 - y0),
                      s.at(0.0, 0.03 - y0));
        }
      std::fflush(stdout);
    }

    // ---- DEM runs
    std::ostringstream tab;
    tab << "N,seed,mean_radius_m,particles_source,particles_ground,k";
    for (const auto& p : points) tab << ",phi_" << p.name << ",ref_" << p.name << ",ref_band_" << p.name << ",error_pct_" << p.name;
    tab << ",phi_mean_P1,phi_mean_P2,ground_centre_y_m,source_centre_rmax_m,electrical_solve_s,electrical_stage_s,run_time_s,cpu_time_s\n";
    for (const fs::path& d : runs) {
      const json scene = read_json(d / "scene.json");
      const json summary = read_json(d / "out" / "summary.json");
      double wall = NAN, cpu = NAN;
      if (std::ifstream w(d / "wall_time_s"); w) w >> wall;
      if (std::ifstream w(d / "cpu_time_s"); w) w >> cpu;
      const plate::Frame fr = plate::read_last_frame(d / "out");
      double rbar = 0.0;
      for (double r : fr.radius) rbar += r / static_cast<double>(fr.radius.size());
      const json& st = summary["stages"].back();
      char line[512];
      std::snprintf(line, sizeof line, "%lld,%lld,%.6e,%lld,%lld,%zu",
                    static_cast<long long>(scene["stages"][0]["generator"]["particles"].get<std::int64_t>()),
                    static_cast<long long>(scene["seed"].get<std::int64_t>()), rbar,
                    static_cast<long long>(st["particle_sets"]["source"].get<std::int64_t>()),
                    static_cast<long long>(st["particle_sets"]["ground"].get<std::int64_t>()), k);
      tab << line;
      std::map<std::string, plate::LineProbe> pr;
      for (const auto& p : points) {
        pr[p.name] = plate::probe_line(fr.position, fr.phi, p.x, p.y, k);
        const Reference& R = ref[p.name];
        std::snprintf(line, sizeof line, ",%.6f,%.6f,%.1e,%.3f", pr[p.name].value, R.value, R.band,
                      100.0 * (pr[p.name].value - R.value) / R.value);
        tab << line;
      }
      double yg = 0.0, ng = 0.0, rs = 0.0;
      for (std::size_t i = 0; i < fr.radius.size(); ++i) {
        if (!fr.ground.empty() && fr.ground[i] > 0.5) {
          yg += fr.position[3 * i + 1];
          ng += 1.0;
        }
        if (!fr.source.empty() && fr.source[i] > 0.5)
          rs = std::max(rs, std::hypot(fr.position[3 * i] - 0.015, fr.position[3 * i + 1] - 0.015));
      }
      std::snprintf(line, sizeof line, ",%.6f,%.6f,%.4e,%.4e,%.4f,%.4f,%.1f,%.1f\n", pr["P1"].mean, pr["P2"].mean, ng > 0 ? yg / ng : NAN,
                    rs, st["final"]["electrical_solve_time"].get<double>(), st["wall_time_s"].get<double>(), wall, cpu);
      tab << line;
    }
    std::cout << tab.str();
    if (!csv.empty() && !runs.empty()) std::ofstream(csv) << tab.str();
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "bench_plate: " << e.what() << "\n";
    return 1;
  }
}
