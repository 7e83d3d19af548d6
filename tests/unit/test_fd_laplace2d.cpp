/// The finite-difference Laplace solver of tests/support/fd_laplace2d.hpp (the reference of the
/// thick-plate validation) against closed-form harmonic functions: the curved Dirichlet boundary
/// (Shortley–Weller), the zero-flux edges (mirror nodes) and the observed order of convergence.
#include <catch2/catch.hpp>

#include <cmath>

#include "support/fd_laplace2d.hpp"

namespace test_fd_laplace2d {

using namespace sparkdem;

namespace {
constexpr double kPi = 3.14159265358979323846;

/// Largest nodal error of a solution against phi_exact (nodes outside the disc).
template <class F>
double max_error(const fd::Solution& s, F exact) {
  double e = 0.0;
  for (int j = 0; j <= s.ny; ++j)
    for (int i = 0; i <= s.nx; ++i)
      if (!std::isnan(s.node(i, j))) e = std::max(e, std::abs(s.node(i, j) - exact(i * s.h, j * s.h)));
  return e;
}
}  // namespace

TEST_CASE("fd Laplace: a linear profile between two Dirichlet edges is exact", "[fd][unit]") {
  // phi = y / L with phi = 0 on y = 0, 1 on y = L, zero flux on x = 0, L: the 5-point stencil and
  // the mirror nodes reproduce a linear function exactly (round-off, 1e-12).
  fd::Problem pb;
  pb.lx = 0.02;
  pb.ly = 0.03;
  pb.ylo = {fd::Edge::Kind::Dirichlet, [](double, double) { return 0.0; }};
  pb.yhi = {fd::Edge::Kind::Dirichlet, [](double, double) { return 1.0; }};
  const fd::Solution s = fd::solve(pb, 20);
  CHECK(s.ny == 30);
  CHECK(max_error(s, [&](double, double y) { return y / pb.ly; }) < 1e-12);
  CHECK(s.at(0.0123, 0.0171) == Approx(0.0171 / 0.03).margin(1e-12));  // bilinear: exact for linear data
}

TEST_CASE("fd Laplace: annulus ln(r/b)/ln(a/b) cut out of a square converges at second order", "[fd][unit]") {
  // Square 30 mm with a hole of radius a = 3 mm at its centre; phi = ln(r/b) / ln(a/b), b = 30 mm,
  // harmonic, = 1 on the circle; the square's edges take the exact values. Shortley–Weller at the
  // circle: the nodal error must fall like h^2. Measured max errors (h = 30/60, 30/120, 30/240 mm):
  // 2.3e-4, 6.3e-5, 1.6e-5 (observed orders 1.87, 2.01); checked: error at h = 30/240 mm below
  // 3e-5 and the observed orders between 1.8 and 2.2.
  const double a = 0.003, b = 0.03, c = 0.015;
  const auto exact = [=](double x, double y) { return std::log(std::hypot(x - c, y - c) / b) / std::log(a / b); };
  fd::Problem pb;
  pb.lx = pb.ly = 0.03;
  for (fd::Edge* e : {&pb.xlo, &pb.xhi, &pb.ylo, &pb.yhi}) *e = {fd::Edge::Kind::Dirichlet, exact};
  pb.disc = true;
  pb.cx = pb.cy = c;
  pb.radius = a;
  pb.disc_value = exact;
  double err[3];
  int k = 0;
  for (int n : {60, 120, 240}) {
    const fd::Solution s = fd::solve(pb, n);
    CHECK(s.cut_arms > 0);
    err[k++] = max_error(s, exact);
  }
  INFO("max errors " << err[0] << " " << err[1] << " " << err[2]);
  CHECK(err[2] < 3e-5);
  const double p1 = std::log2(err[0] / err[1]), p2 = std::log2(err[1] / err[2]);
  INFO("observed orders " << p1 << " " << p2);
  CHECK(p1 > 1.8);
  CHECK(p1 < 2.2);
  CHECK(p2 > 1.8);
  CHECK(p2 < 2.2);
}

TEST_CASE("fd Laplace: zero-flux edges (mirror nodes) converge at second order", "[fd][unit]") {
  // phi = cos(pi x / L) cosh(pi (L - y) / L) / cosh(pi): harmonic, d phi / dn = 0 on x = 0, x = L
  // and y = L, phi = cos(pi x / L) on y = 0 (Dirichlet). Three zero-flux edges as in the plate.
  // Measured max errors (h = L/40, L/80, L/160): 2.0e-4, 5.0e-5, 1.25e-5 (order 2.00). Checked:
  // error at h = L/160 below 2e-5 and observed orders between 1.9 and 2.1.
  const double L = 0.03;
  const auto exact = [=](double x, double y) { return std::cos(kPi * x / L) * std::cosh(kPi * (L - y) / L) / std::cosh(kPi); };
  fd::Problem pb;
  pb.lx = pb.ly = L;
  pb.ylo = {fd::Edge::Kind::Dirichlet, exact};
  double err[3];
  int k = 0;
  for (int n : {40, 80, 160}) err[k++] = max_error(fd::solve(pb, n), exact);
  INFO("max errors " << err[0] << " " << err[1] << " " << err[2]);
  CHECK(err[2] < 2e-5);
  for (int m = 0; m < 2; ++m) {
    const double p = std::log2(err[m] / err[m + 1]);
    INFO("observed order " << p);
    CHECK(p > 1.9);
    CHECK(p < 2.1);
  }
}

TEST_CASE("fd Laplace: Richardson extrapolation of a second-order sequence", "[fd][unit]") {
  // f(h) = f0 + c h^2 exactly: the observed order is 2, the extrapolation is f0 and the band is
  // the finest grid's estimated error |f3 - f2| / 3 (= c h3^2, exact here), to round-off.
  const auto f = [](double h) { return 0.25 + 3.0 * h * h; };
  const fd::Richardson r = fd::richardson(f(0.1), f(0.05), f(0.025));
  CHECK(r.observed_order == Approx(2.0).epsilon(1e-9));
  CHECK(r.extrapolated == Approx(0.25).epsilon(1e-12));
  CHECK(r.band == Approx((f(0.05) - f(0.025)) / 3.0).epsilon(1e-9));
  CHECK_THROWS_AS(fd::solve(fd::plate_problem(0.03, 0.0149), 60), std::invalid_argument);  // disc touches the edges
}

}  // namespace test_fd_laplace2d
