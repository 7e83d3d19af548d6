#pragma once
/// The thick-plate validation of seed 001 (§3.2): the potential of the DEM solution at a control
/// point of the plate, and the run of the scenario that produces it. Shared by
/// tests/scenario/test_plate_source.cpp and benchmarks/plate_source/bench_plate.cpp.
///
/// Definition of the DEM potential at a control point (x0, y0) of the plate. The source and the
/// ground go through the whole depth, so the continuum field does not depend on z and the point
/// stands for the line {x = x0, y = y0} through the depth. The DEM gives potentials at particle
/// centres only. We take the k particles whose centres are nearest that line (in-plane distance
/// d_i = |(x_i - x0, y_i - y0)|, every depth), fit phi ~ a + b (x - x0) + c (y - y0) to their
/// potentials by least squares, and report a. The linear fit is unbiased for a field that varies
/// linearly over the neighbourhood, also when the neighbours lie on one side of the point (the
/// corner P2, where they fill a quarter disc); a plain mean would be biased by the gradient
/// times the offset of the neighbours' centroid, which does not vanish at a boundary point. The
/// plain mean is reported beside it as a diagnostic. Particles with a NaN potential (floating
/// clusters) are left out. k = 24 by default: enough for a well-posed 3-parameter fit, and a
/// neighbourhood of about 1.5-3 mean radii in the plane for the N of the seed.
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/hdf5/h5file.hpp"

namespace sparkdem::plate {

struct LineProbe {
  double value = 0.0;     ///< linear least-squares fit evaluated at the point [V]
  double mean = 0.0;      ///< plain mean of the k potentials [V] (diagnostic)
  std::size_t count = 0;  ///< k
  double reach = 0.0;     ///< in-plane distance of the farthest of the k centres [m]
};

/// The probe of the header comment. `position` holds 3 n coordinates (x, y, z per particle),
/// `phi` n potentials. Throws std::invalid_argument with fewer than 3 usable particles or
/// when the k centres are collinear in the plane.
inline LineProbe probe_line(const std::vector<double>& position, const std::vector<double>& phi, double x0, double y0, std::size_t k = 24) {
  if (position.size() != 3 * phi.size()) throw std::invalid_argument("plate::probe_line: position must hold 3 values per potential");
  std::vector<std::size_t> idx;
  std::vector<double> d(phi.size());
  for (std::size_t i = 0; i < phi.size(); ++i) {
    d[i] = std::hypot(position[3 * i] - x0, position[3 * i + 1] - y0);
    if (std::isfinite(phi[i])) idx.push_back(i);
  }
  k = std::min(k, idx.size());
  if (k < 3) throw std::invalid_argument("plate::probe_line: fewer than 3 particles with a potential");
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(k), idx.end(),
                    [&](std::size_t a, std::size_t b) { return d[a] < d[b] || (d[a] == d[b] && a < b); });
  Eigen::MatrixXd A(k, 3);
  Eigen::VectorXd rhs(k);
  LineProbe out;
  out.count = k;
  for (std::size_t m = 0; m < k; ++m) {
    const std::size_t i = idx[m];
    A(m, 0) = 1.0;
    A(m, 1) = position[3 * i] - x0;
    A(m, 2) = position[3 * i + 1] - y0;
    rhs[m] = phi[i];
    out.mean += phi[i] / static_cast<double>(k);
    out.reach = std::max(out.reach, d[i]);
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < 3) throw std::invalid_argument("plate::probe_line: the nearest centres are collinear in the plane");
  out.value = qr.solve(rhs)[0];
  return out;
}

/// Particle positions and potentials of the last frame of a run directory.
struct Frame {
  std::vector<double> position, phi, radius;
  std::vector<double> ground, source;  ///< set membership (1 = member), if the frame holds the sets
};
inline Frame read_last_frame(const std::filesystem::path& outdir) {
  std::filesystem::path last;
  for (const auto& e : std::filesystem::directory_iterator(outdir / "frames"))
    if (e.path().extension() == ".h5" && (last.empty() || e.path().filename() > last.filename())) last = e.path();
  if (last.empty()) throw std::runtime_error("plate::read_last_frame: no frame in " + (outdir / "frames").string());
  const auto f = io::H5File::open_read(last);
  Frame fr;
  fr.position = f.read_doubles("/particles/position");
  fr.phi = f.read_doubles("/particles/electric_potential");
  fr.radius = f.read_doubles("/particles/radius");
  fr.ground = f.read_doubles("/particles/set_ground");
  fr.source = f.read_doubles("/particles/set_source");
  return fr;
}

/// Control points of the plate (side L, source radius a, source at the centre), in m.
struct ControlPoint {
  const char* name;
  double x, y;
};
inline std::vector<ControlPoint> control_points(double side = 0.030, double source_radius = 0.003) {
  const double c = 0.5 * side;
  return {{"P1", c, 0.5 * (c - source_radius)},  // halfway between the ground and the source's nearest edge
          {"P1c", c, 0.5 * c},                   // alternative: halfway between the ground and the source centre
          {"P2", 0.0, side}};                    // the top-left corner
}

}  // namespace sparkdem::plate
