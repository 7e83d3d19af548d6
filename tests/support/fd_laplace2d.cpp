// fd::solve, compiled once (library sparkdem_reference, tools/CMakeLists.txt): Eigen's SparseLU is
// instantiated here only, not in every test, benchmark and tool that includes the header.
#include "support/fd_laplace2d.hpp"

#include <Eigen/OrderingMethods>
#include <Eigen/SparseLU>

namespace sparkdem::fd {

Solution solve(const Problem& pb, int nx) {
  if (!(pb.lx > 0.0) || !(pb.ly > 0.0) || nx < 2) throw std::invalid_argument("fd::solve: needs lx, ly > 0 and nx >= 2");
  Solution s;
  s.nx = nx;
  s.h = pb.lx / nx;
  const double h = s.h;
  s.ny = static_cast<int>(std::lround(pb.ly / h));
  if (s.ny < 2 || std::abs(s.ny * h - pb.ly) > 1e-9 * pb.ly)
    throw std::invalid_argument("fd::solve: ly = " + std::to_string(pb.ly) + " m is not a multiple of h = " + std::to_string(h) + " m");
  const int ny = s.ny, W = nx + 1;
  if (pb.disc && (!(pb.radius > 0.0) || pb.cx - pb.radius < h || pb.cy - pb.radius < h || pb.cx + pb.radius > pb.lx - h ||
                  pb.cy + pb.radius > pb.ly - h))
    throw std::invalid_argument("fd::solve: the disc must lie at least one cell inside the rectangle");
  for (const Edge* e : {&pb.xlo, &pb.xhi, &pb.ylo, &pb.yhi})
    if (e->kind == Edge::Kind::Dirichlet && !e->value) throw std::invalid_argument("fd::solve: a Dirichlet edge needs a value");
  if (pb.disc && !pb.disc_value) throw std::invalid_argument("fd::solve: the disc needs a value");

  const auto X = [h](int i) { return i * h; };
  const auto Y = [h](int j) { return j * h; };
  const auto in_disc = [&](double x, double y) {
    return pb.disc && (x - pb.cx) * (x - pb.cx) + (y - pb.cy) * (y - pb.cy) <= pb.radius * pb.radius;
  };
  // Node status: -1 Dirichlet edge, -2 disc, >= 0 unknown number.
  std::vector<int> id(static_cast<std::size_t>(W * (ny + 1)), 0);
  s.phi.assign(id.size(), 0.0);
  int n = 0;
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const std::size_t k = static_cast<std::size_t>(i + W * j);
      const Edge* dir = nullptr;
      if (i == 0 && pb.xlo.kind == Edge::Kind::Dirichlet) dir = &pb.xlo;
      if (i == nx && pb.xhi.kind == Edge::Kind::Dirichlet) dir = &pb.xhi;
      if (j == 0 && pb.ylo.kind == Edge::Kind::Dirichlet) dir = &pb.ylo;
      if (j == ny && pb.yhi.kind == Edge::Kind::Dirichlet) dir = &pb.yhi;
      if (in_disc(X(i), Y(j))) {
        id[k] = -2;
        s.phi[k] = std::numeric_limits<double>::quiet_NaN();
      } else if (dir) {
        id[k] = -1;
        s.phi[k] = dir->value(X(i), Y(j));
      } else {
        id[k] = n++;
      }
    }
  s.unknowns = n;
  std::vector<Eigen::Triplet<double>> trip;
  trip.reserve(static_cast<std::size_t>(5 * n));
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
  // Distance t in (0, h] from (x, y) along unit direction (dx, dy) to the circle (the node is outside).
  const auto cut = [&](double x, double y, double dx, double dy) {
    const double px = x - pb.cx, py = y - pb.cy;
    const double b = dx * px + dy * py, c = px * px + py * py - pb.radius * pb.radius;
    const double t = -b - std::sqrt(std::max(b * b - c, 0.0));
    return std::clamp(t, 1e-12 * h, h);
  };
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      const int row = id[static_cast<std::size_t>(i + W * j)];
      if (row < 0) continue;
      const double x = X(i), y = Y(j);
      double diag = 0.0;
      // One grid direction: the two arms (minus, plus). A missing neighbour beyond a zero-flux
      // edge is the mirror node on the other side.
      const auto direction = [&](int im, int jm, int ip, int jp, double dx, double dy) {
        double hh[2] = {h, h}, val[2] = {0.0, 0.0};
        int col[2] = {-1, -1};
        const int ii[2] = {im, ip}, jj[2] = {jm, jp};
        const double sgn[2] = {-1.0, 1.0};
        for (int a = 0; a < 2; ++a) {
          int qi = ii[a], qj = jj[a];
          if (qi < 0) qi = 1;
          if (qi > nx) qi = nx - 1;
          if (qj < 0) qj = 1;
          if (qj > ny) qj = ny - 1;
          const int q = id[static_cast<std::size_t>(qi + W * qj)];
          if (q == -2) {  // the arm crosses the circle: Shortley–Weller
            hh[a] = cut(x, y, sgn[a] * dx, sgn[a] * dy);
            val[a] = pb.disc_value(x + sgn[a] * dx * hh[a], y + sgn[a] * dy * hh[a]);
            ++s.cut_arms;
          } else if (q == -1) {
            val[a] = s.phi[static_cast<std::size_t>(qi + W * qj)];
          } else {
            col[a] = q;
          }
        }
        // -(h^2) x the unequal-spacing second difference (positive diagonal).
        const double cm = 2.0 * h * h / (hh[0] * (hh[0] + hh[1])), cp = 2.0 * h * h / (hh[1] * (hh[0] + hh[1]));
        diag += cm + cp;
        const double c[2] = {cm, cp};
        for (int a = 0; a < 2; ++a) {
          if (col[a] >= 0)
            trip.emplace_back(row, col[a], -c[a]);
          else
            rhs[row] += c[a] * val[a];
        }
      };
      direction(i - 1, j, i + 1, j, 1.0, 0.0);
      direction(i, j - 1, i, j + 1, 0.0, 1.0);
      trip.emplace_back(row, row, diag);
    }
  Eigen::SparseMatrix<double> A(n, n);
  A.setFromTriplets(trip.begin(), trip.end());  // duplicates (mirror arms) are summed
  A.makeCompressed();
  Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
  lu.compute(A);
  if (lu.info() != Eigen::Success) throw std::runtime_error("fd::solve: sparse LU factorisation failed: " + lu.lastErrorMessage());
  const Eigen::VectorXd u = lu.solve(rhs);
  for (std::size_t k = 0; k < id.size(); ++k)
    if (id[k] >= 0) s.phi[k] = u[id[k]];
  return s;
}

}  // namespace sparkdem::fd
