// The cpc_fillers algorithms (seed 002 contact algorithm and aggregation), called directly.
//
// Closed forms and invariants:
//  - a lone overlapping pair: each gradient step multiplies the overlap by (1 - 2 gamma) = 0.2, so
//    the algorithm stops after ceil(ln(tol (2R) / delta) / ln 0.2) steps with the overlap
//    delta 0.2^k (exact up to rounding, tolerance 1e-12 relative);
//  - a random configuration: after the contact algorithm the largest relative overlap (brute
//    force over all pairs) is <= 1e-3; N and R are unchanged, so phi = N 4/3 pi R^3 / L^3 is
//    exactly the generated one; centres stay within a few R of the box; the result is a
//    deterministic function of the seed (bit-identical reruns, a different seed differs);
//  - aggregation: lambda = 0 moves nothing; lambda larger than the box diagonal moves every
//    particle outside the seed cluster, each into exact contact with an earlier member, so
//    afterwards the contact graph (tolerance 1e-9) is ONE cluster of all N particles; particles
//    of the seed cluster never move; after the second contact algorithm no overlap exceeds 1e-3.
#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "physics/packing/cpc_fillers.hpp"
#include "physics/packing/size_distribution.hpp"

namespace test_cpc_fillers {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {
constexpr double kPi = std::numbers::pi;

std::vector<Vec3> random_centres(std::size_t n, double L, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Vec3> x(n);
  for (auto& p : x)
    for (int d = 0; d < 3; ++d) p[d] = L * uniform_open01(rng);
  return x;
}
double brute_max_overlap(const std::vector<Vec3>& x, const std::vector<double>& r) {
  double m = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j) m = std::max(m, 1.0 - (x[i] - x[j]).norm() / (r[i] + r[j]));
  return m;
}
std::size_t largest_cluster(const std::vector<Vec3>& x, const std::vector<double>& r, double tol) {
  const auto lab = cpc::cluster_labels(x.size(), cpc::contact_pairs(x, r, tol));
  std::vector<std::size_t> size(x.size(), 0);
  for (Index l : lab) ++size[l];
  return *std::max_element(size.begin(), size.end());
}
}  // namespace

TEST_CASE("cpc_fillers: a lone pair loses 80 % of its overlap per step", "[cpc]") {
  const double R = 1.0, delta = 0.5, tol = 1e-3;
  std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(2 * R - delta, 0, 0)};
  const std::vector<double> r = {R, R};
  const auto o = cpc::remove_overlaps(x, r, 0.4, tol, 1000);
  const int k = static_cast<int>(std::ceil(std::log(tol * 2 * R / delta) / std::log(0.2)));
  CHECK(o.converged);
  CHECK(o.iterations == k);
  const double overlap = 2 * R - (x[1] - x[0]).norm();
  CHECK(std::abs(overlap - delta * std::pow(0.2, k)) < 1e-12 * delta);
  CHECK(std::abs(o.max_overlap - overlap / (2 * R)) < 1e-12);
  // The pair's midpoint does not move (equal and opposite steps).
  CHECK(std::abs(0.5 * (x[0].x() + x[1].x()) - 0.5 * (2 * R - delta)) < 1e-12);
}

TEST_CASE("cpc_fillers: contact algorithm on a random configuration", "[cpc]") {
  const double R = 1.0, L = 24.0, phi = 0.25;
  const auto n = static_cast<std::size_t>(std::round(phi * L * L * L / (4.0 / 3.0 * kPi)));
  const std::vector<double> r(n, R);
  std::vector<Vec3> x = random_centres(n, L, 5);
  REQUIRE(brute_max_overlap(x, r) > 0.5);  // the random start overlaps heavily
  const auto o = cpc::remove_overlaps(x, r, 0.4, 1e-3, 100000);
  REQUIRE(o.converged);
  CHECK(o.iterations > 10);
  const double worst = brute_max_overlap(x, r);
  CHECK(worst <= 1e-3);
  CHECK(std::abs(worst - o.max_overlap) < 1e-14);
  CHECK(std::abs(cpc::max_relative_overlap(x, r) - worst) < 1e-14);
  // Volume fraction: N and R unchanged; the configuration stays in the box up to a few radii.
  CHECK(x.size() == n);
  CHECK(std::abs(n * 4.0 / 3.0 * kPi / (L * L * L) - phi) < 0.5 * 4.0 / 3.0 * kPi / (L * L * L));
  for (const auto& p : x) CHECK(((p.array() > -3 * R).all() && (p.array() < L + 3 * R).all()));
  // Deterministic by seed.
  std::vector<Vec3> y = random_centres(n, L, 5), z = random_centres(n, L, 6);
  cpc::remove_overlaps(y, r, 0.4, 1e-3, 100000);
  cpc::remove_overlaps(z, r, 0.4, 1e-3, 100000);
  bool same = true, differ = false;
  for (std::size_t i = 0; i < n; ++i) {
    same = same && (x[i] == y[i]);
    differ = differ || !(x[i] == z[i]);
  }
  CHECK(same);
  CHECK(differ);
}

TEST_CASE("cpc_fillers: aggregation", "[cpc]") {
  const double R = 1.0, L = 20.0, phi = 0.08;
  const auto n = static_cast<std::size_t>(std::round(phi * L * L * L / (4.0 / 3.0 * kPi)));
  const std::vector<double> r(n, R);
  std::vector<Vec3> x0 = random_centres(n, L, 11);
  REQUIRE(cpc::remove_overlaps(x0, r, 0.4, 1e-3, 100000).converged);
  const std::size_t seed_size = largest_cluster(x0, r, 1e-3);
  REQUIRE(seed_size < n / 4);  // phi = 8 %: far below the threshold, small clusters
  SECTION("lambda = 0 moves nothing") {
    std::vector<Vec3> x = x0;
    std::mt19937_64 rng(1);
    const auto a = cpc::aggregate(x, r, 0.0, 1e-3, rng);
    CHECK(a.moved == 0);
    CHECK(a.seed_cluster == seed_size);
    CHECK(a.examined == n - seed_size);
    for (std::size_t i = 0; i < n; ++i) CHECK(x[i] == x0[i]);
  }
  SECTION("lambda beyond the box diagonal: one cluster of all particles") {
    std::vector<Vec3> x = x0;
    std::mt19937_64 rng(1);
    const auto a = cpc::aggregate(x, r, 2.0 * std::sqrt(3.0) * L / R, 1e-3, rng);
    CHECK(a.moved == a.examined);
    CHECK(a.examined == n - seed_size);
    CHECK(largest_cluster(x, r, 1e-9) == n);
    // Seed-cluster particles did not move.
    std::size_t unmoved = 0;
    for (std::size_t i = 0; i < n; ++i) unmoved += x[i] == x0[i];
    CHECK(unmoved >= seed_size);
    REQUIRE(cpc::remove_overlaps(x, r, 0.4, 1e-3, 100000).converged);
    CHECK(brute_max_overlap(x, r) <= 1e-3);
  }
  SECTION("moderate lambda: fewer, larger clusters than the homogeneous configuration") {
    std::vector<Vec3> x = x0;
    std::mt19937_64 rng(1);
    const auto a = cpc::aggregate(x, r, 6.0, 1e-3, rng);
    CHECK(a.moved > 0);
    CHECK(a.moved < a.examined);
    REQUIRE(cpc::remove_overlaps(x, r, 0.4, 1e-3, 100000).converged);
    CHECK(brute_max_overlap(x, r) <= 1e-3);
    const auto count = [&](const std::vector<Vec3>& y) {
      const auto lab = cpc::cluster_labels(n, cpc::contact_pairs(y, r, 1e-3));
      std::size_t c = 0;
      for (std::size_t i = 0; i < n; ++i) c += lab[i] == static_cast<Index>(i);
      return c;
    };
    CHECK(count(x) < count(x0));
    CHECK(largest_cluster(x, r, 1e-3) > seed_size);
  }
}

}  // namespace test_cpc_fillers
