#pragma once
/// Finite-difference reference solver for the 2-D Laplace equation on a rectangle with an
/// optional circular Dirichlet hole. Written as the reference of the thick-plate validation of
/// seed 001 (§3.2; physics note §7.2), independent of the engine (it uses only Eigen).
///
/// Problem:   lap(phi) = d2phi/dx2 + d2phi/dy2 = 0   in  Omega = (0, lx) x (0, ly) minus the disc
///            |x - c| <= R;
///            phi = g_disc(x, y) on the circle |x - c| = R;
///            on each edge (x = 0, x = lx, y = 0, y = ly) either phi = g_edge(x, y) (Dirichlet) or
///            d phi / dn = 0 (zero normal flux).
///
/// Method:    uniform grid x_i = i h (i = 0..nx), y_j = j h (j = 0..ny), ny h = ly; one unknown per
///            node outside the disc and not on a Dirichlet edge; 5-point stencil.
///  * Curved boundary (Shortley & Weller 1938): when a stencil arm from node P crosses the circle
///    before the next node, the arm is cut at the crossing, at distance theta h (0 < theta <= 1),
///    where phi = g_disc; along that grid line the second derivative is the three-point formula
///    on unequal spacings hm (backward) and hp (forward):
///        d2phi/dx2 ~ 2 / (hm + hp) * ((phi_+ - phi_P) / hp - (phi_P - phi_-) / hm),
///    which is first-order consistent at such nodes and gives a second-order accurate solution
///    (the discrete operator is monotone: an M-matrix, so the discrete maximum principle holds).
///  * Zero-flux edges: a mirror (ghost) node, phi_{-1} = phi_1, i.e. the centred difference of the
///    normal derivative is zero (second order).
///  * Dirichlet edges: the nodes on them take g_edge; where a Dirichlet edge meets a zero-flux
///    edge, the corner node is Dirichlet.
///  * Linear system: non-symmetric (Shortley–Weller rows), solved with Eigen's SparseLU (COLAMD
///    ordering), a direct solver, so there is no iteration tolerance in the error budget.
/// Grid convergence and Richardson extrapolation: `richardson()` below, on three grids h, h/2, h/4.

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sparkdem::fd {

/// Boundary condition of one edge of the rectangle.
struct Edge {
  enum class Kind { Dirichlet, ZeroFlux };
  Kind kind = Kind::ZeroFlux;
  std::function<double(double, double)> value;  ///< Dirichlet: phi(x, y) on the edge
};

/// The boundary-value problem (lengths in m; phi in any unit, here V).
struct Problem {
  double lx = 0.0, ly = 0.0;
  Edge xlo, xhi, ylo, yhi;
  bool disc = false;  ///< a circular hole with phi = disc_value on its boundary
  double cx = 0.0, cy = 0.0, radius = 0.0;
  std::function<double(double, double)> disc_value;
};

/// Nodal solution on the grid; NaN at nodes inside (or on) the disc.
struct Solution {
  int nx = 0, ny = 0;
  double h = 0.0;
  std::vector<double> phi;  ///< (nx + 1) (ny + 1) values, index i + (nx + 1) j
  int unknowns = 0;
  int cut_arms = 0;  ///< stencil arms shortened by the Shortley–Weller treatment
  double node(int i, int j) const { return phi[static_cast<std::size_t>(i + (nx + 1) * j)]; }
  /// phi at (x, y): bilinear interpolation in the grid cell (exact at nodes). Throws
  /// std::domain_error outside the rectangle or when a corner of the cell lies in the disc.
  double at(double x, double y) const {
    const double lx = nx * h, ly = ny * h, eps = 1e-9 * h;
    if (x < -eps || y < -eps || x > lx + eps || y > ly + eps) throw std::domain_error("fd::Solution::at: point outside the rectangle");
    const double u = std::clamp(x / h, 0.0, static_cast<double>(nx)), v = std::clamp(y / h, 0.0, static_cast<double>(ny));
    int i = std::min(static_cast<int>(std::floor(u + 1e-9)), nx - 1), j = std::min(static_cast<int>(std::floor(v + 1e-9)), ny - 1);
    const double a = u - i, b = v - j;
    double sum = 0.0;
    for (int dj = 0; dj <= 1; ++dj)
      for (int di = 0; di <= 1; ++di) {
        const double w = (di ? a : 1.0 - a) * (dj ? b : 1.0 - b);
        if (w == 0.0) continue;
        const double p = node(i + di, j + dj);
        if (std::isnan(p)) throw std::domain_error("fd::Solution::at: the cell touches the disc");
        sum += w * p;
      }
    return sum;
  }
};

/// Solve the problem on the grid of nx cells in x (h = lx / nx; ly must be a multiple of h).
/// Compiled once in fd_laplace2d.cpp (library sparkdem_reference, tools/CMakeLists.txt).
/// Throws std::invalid_argument for an inconsistent grid or a disc that is not at least one
/// cell inside the rectangle, and std::runtime_error when the factorisation fails.
Solution solve(const Problem& pb, int nx);

/// Richardson extrapolation from three grids with refinement ratio 2 (f1 on h, f2 on h/2, f3 on
/// h/4): observed order p = log2((f1 - f2) / (f2 - f3)); extrapolated value with the formal
/// order 2 of the scheme, f = f3 + (f3 - f2) / 3. Error band: |f3 - f2| / 3 (the estimated error
/// left on the finest grid) plus the distance to the extrapolation with the observed order, so
/// an observed order away from 2 widens it; without a clean observed order (the differences
/// change sign) the band is |f1 - f2| + |f2 - f3|.
struct Richardson {
  double observed_order = 0.0;
  double extrapolated = 0.0;  ///< with the formal order 2
  double band = 0.0;          ///< half-width of the error band of `extrapolated`
};
inline Richardson richardson(double f1, double f2, double f3) {
  Richardson r;
  const double d12 = f1 - f2, d23 = f2 - f3;
  r.observed_order = (d12 != 0.0 && d23 != 0.0 && d12 / d23 > 0.0) ? std::log2(d12 / d23) : std::numeric_limits<double>::quiet_NaN();
  r.extrapolated = f3 - d23 / 3.0;
  if (std::isfinite(r.observed_order) && r.observed_order > 0.0) {
    const double fp = f3 - d23 / (std::pow(2.0, r.observed_order) - 1.0);
    r.band = std::abs(d23) / 3.0 + std::abs(fp - r.extrapolated);
  } else {
    r.band = std::abs(d12) + std::abs(d23);
  }
  return r;
}

/// The thick plate of seed 001 §3.2 in the plane of the plate (the source and the ground go
/// through the whole depth, so the problem is 2-D): square of side `side` [m], phi = 0 on
/// y = 0, phi = 1 on the circle of radius `source_radius` about the centre, zero flux elsewhere.
inline Problem plate_problem(double side = 0.030, double source_radius = 0.003) {
  Problem pb;
  pb.lx = pb.ly = side;
  pb.ylo.kind = Edge::Kind::Dirichlet;
  pb.ylo.value = [](double, double) { return 0.0; };
  pb.disc = true;
  pb.cx = pb.cy = 0.5 * side;
  pb.radius = source_radius;
  pb.disc_value = [](double, double) { return 1.0; };
  return pb;
}

}  // namespace sparkdem::fd
