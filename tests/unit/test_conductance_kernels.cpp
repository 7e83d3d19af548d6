// Branch conductance kernels (physics/electrical/conductance_kernels.hpp) against closed forms and
// the tables of the physics notes: Holm constriction, the series law of Eq. 18 with its limits,
// the hemisphere readings A/B/C, the FE table and the positive floor, Coble and constant-volume
// necks (the note's table, the unequal case, volume conservation, the small-overlap limit), the
// grain-boundary-fraction correction (Eq. 23 after correction), eccentricity and alpha(n) on a
// simple cubic lattice, the lattice-of-columns resistance rho l / A, touching / tunnelling, and
// both kappa(T) laws. Each check states its tolerance.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "engine/core/error.hpp"
#include "physics/electrical/conductance_kernels.hpp"
#include "tests/support/tolerance.hpp"

namespace test_conductance_kernels {

using namespace sparkdem;
using namespace sparkdem::physics::electrical;
using sparkdem::test::relative_error;

namespace {

constexpr double kPiT = std::numbers::pi;
constexpr double kKappa = 9.8e6;  // NiAl-like bulk conductivity [S/m] (seed 000)

/// Volume of the collar of radius a outside sphere k between z_k = sqrt(r^2 - a^2) and the plane
/// at d_k, written exactly as in sintering-electrical.md §2.5 (not the kernel's rearranged form).
double note_collar_volume(double a, double r, double d) {
  const double z = std::sqrt(r * r - a * a);
  return kPiT * a * a * (d - z) - kPiT * (r * r * (d - z) - (d * d * d - z * z * z) / 3.0);
}
/// Cap volume pi/3 c^2 (3r - c) (§2.5).
double note_cap_volume(double c, double r) { return kPiT / 3.0 * c * c * (3.0 * r - c); }

/// Simple cubic lattice nx x ny x nz with spacing 2r from origin o; nearest-neighbour edges.
struct Lattice {
  std::vector<Vec3> x;
  std::vector<double> r;
  std::vector<Index> a, b;
  int nx, ny, nz;
  Index id(int i, int j, int k) const { return static_cast<Index>((k * ny + j) * nx + i); }
};
Lattice cubic_lattice(int nx, int ny, int nz, double radius, const Vec3& o) {
  Lattice L;
  L.nx = nx;
  L.ny = ny;
  L.nz = nz;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        L.x.push_back(o + 2.0 * radius * Vec3(i, j, k));
        L.r.push_back(radius);
      }
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        if (i + 1 < nx) {
          L.a.push_back(L.id(i, j, k));
          L.b.push_back(L.id(i + 1, j, k));
        }
        if (j + 1 < ny) {
          L.a.push_back(L.id(i, j, k));
          L.b.push_back(L.id(i, j + 1, k));
        }
        if (k + 1 < nz) {
          L.a.push_back(L.id(i, j, k));
          L.b.push_back(L.id(i, j, k + 1));
        }
      }
  return L;
}

}  // namespace

TEST_CASE("Holm constriction conductance and Hertz contact radius: closed forms", "[electrical][conductance]") {
  // Tolerance 1e-14 relative: a few roundings of closed forms.
  const double a = 3e-6;
  CHECK(relative_error(holm_conductance(a, kKappa, kKappa), 2.0 * a * kKappa) < 1e-14);
  const double k1 = 5.8e7, k2 = 1.4e6;  // copper / stainless-like
  const double r_series = 1.0 / (4.0 * a * k1) + 1.0 / (4.0 * a * k2);
  CHECK(relative_error(holm_conductance(a, k1, k2), 1.0 / r_series) < 1e-14);
  CHECK(relative_error(holm_conductance(a, k1, k2), holm_conductance(a, k2, k1)) < 1e-15);
  // A perfect conductor on one side leaves one half-space: 4 a kappa.
  CHECK(relative_error(holm_conductance(a, k1, kInf), 4.0 * a * k1) < 1e-14);
  CHECK(holm_conductance(0.0, k1, k2) == 0.0);
  CHECK_THROWS_AS(holm_conductance(-1e-9, k1, k2), ConfigError);
  CHECK_THROWS_AS(holm_conductance(a, 0.0, k2), ConfigError);
  CHECK_THROWS_AS(holm_conductance(a, k1, std::nan("")), ConfigError);

  // Hertz: a = sqrt(R* delta).
  const double ri = 1e-4, rj = 3e-4, delta = 2e-7;
  const double r_eff = ri * rj / (ri + rj);
  CHECK(relative_error(hertz_contact_radius(ri, rj, delta), std::sqrt(r_eff * delta)) < 1e-14);
  CHECK(relative_error(hertz_contact_radius(ri, kInf, delta), std::sqrt(ri * delta)) < 1e-14);  // plane
  CHECK(hertz_contact_radius(ri, rj, 0.0) == 0.0);
  CHECK(hertz_contact_radius(ri, rj, -1e-7) == 0.0);
  CHECK_THROWS_AS(hertz_contact_radius(0.0, rj, delta), ConfigError);
}

TEST_CASE("Series law of Eq. 18 with its limits", "[electrical][conductance]") {
  // Finite values: Eq. 18 as printed, K_i K_j K_c / (K_i K_j + K_j K_c + K_i K_c); 1e-14 relative.
  const double ki = 3.0, kj = 7.0, kc = 0.5;
  const double eq18 = ki * kj * kc / (ki * kj + kj * kc + ki * kc);
  CHECK(relative_error(series_conductance(ki, kj, kc), eq18) < 1e-14);
  // Order does not matter (up to rounding of the sum, 1e-15).
  CHECK(relative_error(series_conductance(kc, ki, kj), eq18) < 1e-15);
  // K_c -> inf (no grain-boundary layer): K_i K_j / (K_i + K_j), exactly and in the limit.
  const double two = ki * kj / (ki + kj);
  CHECK(relative_error(series_conductance(ki, kj, kInf), two) < 1e-14);
  CHECK(relative_error(series_conductance(ki, kj), two) < 1e-14);
  for (const double big : {1e6, 1e10, 1e14}) {
    // series(K_i, K_j, K_c) = two / (1 + two/K_c): relative deviation two/K_c (+ rounding).
    CHECK(relative_error(series_conductance(ki, kj, big), two) < 1.01 * two / big + 1e-15);
  }
  // Huge finite values: the product form of Eq. 18 overflows, the kernel does not.
  CHECK(relative_error(series_conductance(1e300, 1e300, 1e300), 1e300 / 3.0) < 1e-14);
  // Two shorts leave the third; all shorts give +inf; an open element opens the branch.
  CHECK(series_conductance(kInf, kInf, kc) == kc);
  CHECK(std::isinf(series_conductance(kInf, kInf, kInf)));
  CHECK(series_conductance(ki, 0.0, kInf) == 0.0);
  CHECK_THROWS_AS(series_conductance(ki, -1.0), ConfigError);
  CHECK_THROWS_AS(series_conductance(ki, std::nan("")), ConfigError);
}

TEST_CASE("Hemisphere conductance: readings A/B/C, FE table, Holm limit and positive floor", "[electrical][conductance]") {
  const double r = 20e-6;
  const double kpr = kKappa * kPiT * r;
  // Linear readings at a/r = 0.5 against K = kappa pi r (c1 a/r + c0); 1e-14 relative.
  const double a = 0.5 * r;
  CHECK(relative_error(hemisphere_conductance(HemisphereLaw::reading_a(), kKappa, r, a), kpr * 0.495) < 1e-14);
  CHECK(relative_error(hemisphere_conductance(HemisphereLaw::reading_b(), kKappa, r, a), kpr * 0.655) < 1e-14);
  CHECK(relative_error(hemisphere_conductance(HemisphereLaw::reading_c(), kKappa, r, a), kpr * 0.69) < 1e-14);
  // The default is reading A.
  const HemisphereLaw def;
  CHECK(def.form == HemisphereLaw::Form::Linear);
  CHECK(def.c1 == 1.15);
  CHECK(def.c0 == -0.08);

  // Floor: reading A is <= 0 below a/r = 0.0696; the kernel returns phi 4 kappa a there (1e-14).
  for (const double x : {1e-6, 0.01, 0.05, 0.0695, 0.07}) {
    const double k = hemisphere_conductance(HemisphereLaw::reading_a(), kKappa, r, x * r);
    CHECK(k > 0.0);
    CHECK(relative_error(k, 0.01 * 4.0 * kKappa * x * r) < 1e-14);
  }
  // Above the crossing a/r = 0.08/(1.15 - 0.04/pi) = 0.07034 the linear law is untouched.
  CHECK(relative_error(hemisphere_conductance(HemisphereLaw::reading_a(), kKappa, r, 0.0704 * r), kpr * (1.15 * 0.0704 - 0.08)) < 1e-13);
  // a = 0: no neck, no conductance, for every form (reading B would otherwise give 0.08 kappa pi r).
  CHECK(hemisphere_conductance(HemisphereLaw::reading_b(), kKappa, r, 0.0) == 0.0);
  CHECK(hemisphere_conductance(HemisphereLaw::fe_table(), kKappa, r, 0.0) == 0.0);

  // FE table: the 13 points of sintering-electrical.md §2.4 are reproduced (1e-12 relative).
  const double fx[] = {0.05, 0.10, 0.15, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 0.95, 0.99};
  const double fk[] = {0.059, 0.113, 0.166, 0.216, 0.316, 0.418, 0.525, 0.642, 0.775, 0.936, 1.149, 1.293, 1.449};
  for (int k = 0; k < 13; ++k) {
    CHECK(relative_error(fe_hemisphere_normalised(fx[k]), fk[k]) < 1e-12);
    CHECK(relative_error(hemisphere_conductance(HemisphereLaw::fe_table(), kKappa, r, fx[k] * r), kpr * fk[k]) < 1e-12);
  }
  // Midpoint of a segment: linear interpolation (1e-14).
  CHECK(relative_error(fe_hemisphere_normalised(0.35), 0.5 * (0.316 + 0.418)) < 1e-14);
  // Small a: Holm limit K -> 4 kappa a; the correction is c_b (4x/pi) = 1.58 x relative, so at
  // x = 1e-6 the ratio is 1 within 2e-6.
  CHECK(relative_error(hemisphere_conductance(HemisphereLaw::fe_table(), kKappa, r, 1e-6 * r), 4.0 * kKappa * 1e-6 * r) < 2e-6);
  // Continuity at 0.05 from below (1e-9 relative over a step of 1e-12).
  CHECK(relative_error(fe_hemisphere_normalised(0.05 - 1e-12), 0.059) < 1e-9);
  // x > 1 is clamped at x = 1, the last segment extended: 1.449 + 0.01 (1.449 - 1.293)/0.04.
  const double k1 = 1.449 + 0.01 * (1.449 - 1.293) / 0.04;
  CHECK(relative_error(fe_hemisphere_normalised(1.0), k1) < 1e-12);
  CHECK(relative_error(fe_hemisphere_normalised(1.3), k1) < 1e-12);

  // Every form: K > 0 and non-decreasing in a on a fine grid of a/r in (0, 1] (exact comparisons).
  for (const auto& law : {HemisphereLaw::reading_a(), HemisphereLaw::reading_b(), HemisphereLaw::reading_c(), HemisphereLaw::fe_table()}) {
    double prev = 0.0;
    for (int k = 1; k <= 2000; ++k) {
      const double kk = hemisphere_conductance(law, kKappa, r, k / 2000.0 * r);
      CHECK(kk > prev);
      prev = kk;
    }
  }
  HemisphereLaw bad = HemisphereLaw::reading_a();
  bad.floor_holm_fraction = 0.0;
  CHECK_THROWS_AS(hemisphere_conductance(bad, kKappa, r, a), ConfigError);
  CHECK_THROWS_AS(hemisphere_conductance(def, kKappa, r, -a), ConfigError);
  CHECK_THROWS_AS(hemisphere_conductance(def, kKappa, 0.0, a), ConfigError);
}

TEST_CASE("Grain-boundary layer (Eq. 26) and the sintered-neck branch (Eqs. 17-18)", "[electrical][conductance]") {
  const double a = 4e-6, eps = 0.16, delta = 0.23e-6;
  // K_c = eps kappa pi a^2 / delta; the seed's specific conductance eps kappa/delta = 6.82e12 S/m^2
  // (sintering-electrical.md §2.7, 3 digits: 1e-3).
  CHECK(relative_error(grain_boundary_layer_conductance(kKappa, a, eps, delta), eps * kKappa * kPiT * a * a / delta) < 1e-14);
  CHECK(relative_error(grain_boundary_layer_conductance(kKappa, 1.0 / std::sqrt(kPiT), eps, delta), 6.82e12) < 1e-3);
  CHECK_THROWS_AS(grain_boundary_layer_conductance(kKappa, a, 0.0, delta), ConfigError);
  CHECK_THROWS_AS(grain_boundary_layer_conductance(kKappa, a, eps, 0.0), ConfigError);

  const double ri = 20e-6, rj = 35e-6;
  const auto law = HemisphereLaw::reading_a();
  const double ki = kKappa * kPiT * ri * (1.15 * a / ri - 0.08);
  const double kj = kKappa * kPiT * rj * (1.15 * a / rj - 0.08);
  const double kc = eps * kKappa * kPiT * a * a / delta;
  // With the layer: Eq. 18 as printed (1e-13).
  CHECK(relative_error(sintered_neck_conductance(law, GrainBoundaryLayer::layer(eps, delta), kKappa, kKappa, ri, rj, a),
                       ki * kj * kc / (ki * kj + kj * kc + ki * kc)) < 1e-13);
  // Without ("none"): K_i K_j / (K_i + K_j) (1e-13).
  const double none = sintered_neck_conductance(law, GrainBoundaryLayer::none(), kKappa, kKappa, ri, rj, a);
  CHECK(relative_error(none, ki * kj / (ki + kj)) < 1e-13);
  // Limit K_c -> inf: a very thin layer approaches "none" with relative deviation none/K_c.
  const double thin = 1e-18;
  const double kc_thin = eps * kKappa * kPiT * a * a / thin;
  CHECK(relative_error(sintered_neck_conductance(law, GrainBoundaryLayer::layer(eps, thin), kKappa, kKappa, ri, rj, a), none) <
        1.01 * none / kc_thin + 1e-15);
  // Two materials: the layer uses the harmonic mean 2 k1 k2/(k1 + k2) (1e-13).
  const double k1 = 5.8e7, k2 = 1.4e6, kh = 2.0 * k1 * k2 / (k1 + k2);
  const double hi = k1 * kPiT * ri * (1.15 * a / ri - 0.08);
  const double hj = k2 * kPiT * rj * (1.15 * a / rj - 0.08);
  const double hc = eps * kh * kPiT * a * a / delta;
  CHECK(relative_error(sintered_neck_conductance(law, GrainBoundaryLayer::layer(eps, delta), k1, k2, ri, rj, a),
                       1.0 / (1.0 / hi + 1.0 / hj + 1.0 / hc)) < 1e-13);
  // No neck, no branch.
  CHECK(sintered_neck_conductance(law, GrainBoundaryLayer::none(), kKappa, kKappa, ri, rj, 0.0) == 0.0);
}

TEST_CASE("Coble and constant-volume necks: the note's table, the unequal case, the Coble limit", "[electrical][conductance]") {
  // Coble a = sqrt(2 r* h), r* = 2 r_i r_j/(r_i + r_j); closed forms to 1e-14.
  const double r = 1e-5;
  CHECK(relative_error(coble_neck_radius(r, r, 0.1 * r), std::sqrt(0.2) * r) < 1e-14);
  CHECK(relative_error(coble_neck_radius(r, 10 * r, 0.3 * r), std::sqrt(2.0 * (20.0 / 11.0) * 0.3) * r) < 1e-14);
  // The note's 1.045 (exact 1.04447, printed rounded up): 1e-3.
  CHECK(relative_error(coble_neck_radius(r, 10 * r, 0.3 * r), 1.045 * r) < 1e-3);
  CHECK(relative_error(coble_neck_radius(r, kInf, 0.1 * r), std::sqrt(0.4) * r) < 1e-14);  // plane: r* = 2 r
  CHECK(coble_neck_radius(r, r, 0.0) == 0.0);
  CHECK(cv_neck_radius(r, r, -1e-9) == 0.0);

  // The CV table of sintering-electrical.md §2.5 (equal spheres), 4 digits: 1e-3 relative.
  const double hr[] = {0.005, 0.01, 0.02, 0.05, 0.10, 0.15, 0.20, 0.30, 0.40, 0.50};
  const double cv[] = {0.0999, 0.1412, 0.1993, 0.3136, 0.4396, 0.5337, 0.6106, 0.7336, 0.8297, 0.9068};
  const double co[] = {0.1000, 0.1414, 0.2000, 0.3162, 0.4472, 0.5477, 0.6325, 0.7746, 0.8944, 1.0000};
  for (int k = 0; k < 10; ++k) {
    INFO("h/r = " << hr[k]);
    const double a_cv = cv_neck_radius(r, r, hr[k] * r);
    CHECK(relative_error(a_cv / r, cv[k]) < 1e-3);
    CHECK(relative_error(coble_neck_radius(r, r, hr[k] * r) / r, co[k]) < 1e-3);
    CHECK(a_cv < coble_neck_radius(r, r, hr[k] * r));  // CV is narrower than Coble
  }
  // Unequal: r_j/r_i = 10, h/r_i = 0.3 -> a_CV/r_i = 0.943 (3 digits: 1e-3).
  CHECK(relative_error(cv_neck_radius(r, 10 * r, 0.3 * r) / r, 0.943) < 1e-3);
  // Symmetric in (i, j) (1e-14).
  CHECK(relative_error(cv_neck_radius(10 * r, r, 0.3 * r), cv_neck_radius(r, 10 * r, 0.3 * r)) < 1e-14);

  // Volume conservation with the note's own (unrearranged) collar formula: 1e-9 of the lens
  // volume (the unrearranged form loses ~6 digits to cancellation at h/r = 0.01).
  for (const double ratio : {1.0, 2.5, 10.0}) {
    for (const double h : {0.01, 0.1, 0.3}) {
      INFO("r_j/r_i = " << ratio << ", h/r_i = " << h);
      const double ri = 1.0, rj = ratio, hh = h;
      const double D = ri + rj - hh;
      const double di = (D * D + ri * ri - rj * rj) / (2.0 * D), dj = D - di;
      const double caps = note_cap_volume(ri - di, ri) + note_cap_volume(rj - dj, rj);
      const double a = cv_neck_radius(ri, rj, hh);
      CHECK(a <= std::min(ri, rj));
      const double col = note_collar_volume(a, ri, di) + note_collar_volume(a, rj, dj);
      CHECK(std::abs(col - caps) < 1e-9 * caps);
    }
  }

  // CV -> Coble as h -> 0: the deviation is first order, a_CV/a_Coble = 1 - c h/r_i with
  // c ~ 0.17 (equal), 0.19 (r_j = 3 r_i), 0.28 (r_j = 10 r_i) (own computation; the note's table
  // gives 0.16 at h/r = 0.005). Bound: |a_CV/a_Coble - 1| <= 0.3 h/r_i, checked down to
  // h/r = 1e-10 (bound 3e-11), which also shows that the solver keeps full precision there.
  for (const double ratio : {1.0, 3.0, 10.0}) {
    for (const double h : {1e-10, 1e-8, 1e-6, 1e-4, 1e-3}) {
      INFO("r_j/r_i = " << ratio << ", h/r_i = " << h);
      const double a_cv = cv_neck_radius(r, ratio * r, h * r);
      const double a_co = coble_neck_radius(r, ratio * r, h * r);
      CHECK(std::abs(a_cv / a_co - 1.0) <= 0.3 * h);
      CHECK(a_cv <= a_co);
    }
  }
  // Large overlap: the widest collar cannot hold the lens; capped at r_min (exact).
  CHECK(cv_neck_radius(r, r, 0.8 * r) == r);
  CHECK(cv_neck_radius(r, 10 * r, 1.5 * r) == r);  // small centre inside the big sphere's cap
  CHECK(cv_neck_radius(r, 10 * r, 9.5 * r) == r);  // one sphere inside the other
  CHECK_THROWS_AS(cv_neck_radius(r, kInf, 0.1 * r), ConfigError);
}

TEST_CASE("Grain-boundary-fraction correction (Eqs. 22-25)", "[electrical][conductance]") {
  // Star: particle 0 (r = 1) with 8 necks of 0.9 to particles 1..8 (r = 1): sum a^2 = 6.48 > 4 r^2,
  // alpha_0 = 2/sqrt(6.48). Pair 9-10 (r = 1, 2) with a small neck 0.3: untouched (exact).
  // Node 11: a wall (r = +inf) with a neck 0.5 to particle 10: alpha = 1.
  std::vector<Index> ea, eb;
  std::vector<double> neck;
  for (Index j = 1; j <= 8; ++j) {
    ea.push_back(0);
    eb.push_back(j);
    neck.push_back(0.9);
  }
  ea.push_back(9);
  eb.push_back(10);
  neck.push_back(0.3);
  ea.push_back(10);
  eb.push_back(11);
  neck.push_back(0.5);
  std::vector<double> radius(12, 1.0);
  radius[10] = 2.0;
  radius[11] = kInf;
  const auto alpha = grain_boundary_fraction_factors(ea, eb, neck, radius);
  CHECK(relative_error(alpha[0], 2.0 / std::sqrt(6.48)) < 1e-14);
  for (int j = 1; j <= 11; ++j) CHECK(alpha[static_cast<std::size_t>(j)] == 1.0);
  const auto corr = corrected_neck_radii(ea, eb, neck, radius);
  for (int k = 0; k < 8; ++k) CHECK(relative_error(corr[static_cast<std::size_t>(k)], 0.9 * 2.0 / std::sqrt(6.48)) < 1e-14);
  CHECK(corr[8] == 0.3);
  CHECK(corr[9] == 0.5);
  // Eq. 23 for particle 0, now an equality: sum pi a^2 = 4 pi r^2 (1e-14).
  double s0 = 0.0;
  for (int k = 0; k < 8; ++k) s0 += kPiT * corr[static_cast<std::size_t>(k)] * corr[static_cast<std::size_t>(k)];
  CHECK(relative_error(s0, 4.0 * kPiT) < 1e-14);
  // Cap a <= r_min (§7.9): a single neck of 1.5 between r = 1 and r = 4 becomes 1 (exact).
  const std::vector<Index> pa = {0}, pb = {1};
  const std::vector<double> pn = {1.5}, pr = {1.0, 4.0};
  CHECK(corrected_neck_radii(pa, pb, pn, pr)[0] == 1.0);

  // Random graph: after correction every particle satisfies Eq. 23 (1e-12 relative), necks never
  // grow, none exceeds r_min, and edges whose both end points had alpha = 1 and a <= r_min are
  // unchanged (exact).
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> ur(0.5, 2.0), un(0.0, 1.0);
  const int n = 200;
  std::vector<double> rad(n);
  for (auto& x : rad) x = ur(rng);
  std::vector<Index> ra, rb;
  std::vector<double> rn;
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int k = 0; k < 700; ++k) {
    const int u = pick(rng), v = pick(rng);
    if (u == v) continue;
    ra.push_back(u);
    rb.push_back(v);
    rn.push_back(un(rng) * 1.2 * std::min(rad[static_cast<std::size_t>(u)], rad[static_cast<std::size_t>(v)]));
  }
  const auto al = grain_boundary_fraction_factors(ra, rb, rn, rad);
  const auto rc = corrected_neck_radii(ra, rb, rn, rad);
  std::vector<double> sum(n, 0.0);
  int corrected_nodes = 0, kept_edges = 0;
  for (std::size_t k = 0; k < rc.size(); ++k) {
    const auto u = static_cast<std::size_t>(ra[k]), v = static_cast<std::size_t>(rb[k]);
    CHECK(rc[k] <= rn[k]);
    CHECK(rc[k] <= std::min(rad[u], rad[v]));
    sum[u] += kPiT * rc[k] * rc[k];
    sum[v] += kPiT * rc[k] * rc[k];
    if (al[u] == 1.0 && al[v] == 1.0 && rn[k] <= std::min(rad[u], rad[v])) {
      CHECK(rc[k] == rn[k]);
      ++kept_edges;
    }
  }
  for (int i = 0; i < n; ++i) {
    CHECK(sum[static_cast<std::size_t>(i)] <=
          4.0 * kPiT * rad[static_cast<std::size_t>(i)] * rad[static_cast<std::size_t>(i)] * (1.0 + 1e-12));
    if (al[static_cast<std::size_t>(i)] < 1.0) ++corrected_nodes;
  }
  CHECK(corrected_nodes > 0);  // the test exercises both branches
  CHECK(kept_edges > 0);
  // Deterministic: same input, bit-identical output.
  CHECK(corrected_neck_radii(ra, rb, rn, rad) == rc);

  CHECK_THROWS_AS(corrected_neck_radii(pa, pb, std::vector<double>{-0.1}, pr), ConfigError);
  CHECK_THROWS_AS(corrected_neck_radii(pa, std::vector<Index>{2}, pn, pr), ConfigError);  // node out of range
  CHECK_THROWS_AS(corrected_neck_radii(pa, pb, std::vector<double>{0.1, 0.2}, pr), ConfigError);
}

TEST_CASE("Eccentricity, coordination and alpha(n) on a simple cubic lattice", "[electrical][conductance]") {
  // A 4 x 4 x 4 lattice at an offset origin so that the face eccentricity 0.4 carries round-off.
  const double r = 37e-6;
  const Lattice L = cubic_lattice(4, 4, 4, r, Vec3(0.123456789, -0.0372, 1.0e-3));
  const auto n = coordination_numbers(L.x.size(), L.a, L.b);
  const auto e = eccentricities(L.x, L.r, L.a, L.b);
  const auto model = TransmissionSurfaceModel::platonic();
  const auto s = transmission_surfaces(model, L.x, L.r, L.a, L.b);
  // The note's values (cohesive-joule-torsion.md §3.1): interior 0, face 0.4, edge sqrt2/2, corner
  // 2/sqrt3; positions ~0.12 m with r = 37 um carry ~1e-16 * 0.12/37e-6 ~ 3e-13 of round-off in e:
  // 1e-10 absolute.
  int faces = 0, face_round_off = 0;
  for (int k = 0; k < 4; ++k)
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i) {
        const auto id = static_cast<std::size_t>(L.id(i, j, k));
        const int boundary = (i == 0 || i == 3) + (j == 0 || j == 3) + (k == 0 || k == 3);
        const double expected_e[] = {0.0, 0.4, std::sqrt(0.5), 2.0 / std::sqrt(3.0)};
        CHECK(n[id] == 6 - boundary);
        CHECK(std::abs(e[id] - expected_e[boundary]) < 1e-10);
        // f = 1 inside, 2 on the boundary (face elements included whatever their round-off).
        CHECK(model.eccentricity_factor(e[id]) == (boundary == 0 ? 1.0 : 2.0));
        CHECK(relative_error(s[id], model.alpha(6 - boundary) * r * r / (boundary == 0 ? 1.0 : 2.0)) < 1e-14);
        if (boundary == 1) {
          ++faces;
          if (e[id] < 0.4) ++face_round_off;
        }
      }
  CHECK(faces == 24);
  // Informative only (round-off is platform dependent): on x86-64 with GCC, 12 of the 24 face
  // elements come out below 0.4, so without the tolerance they would get f = 1.
  WARN("face elements whose computed e is below 0.4 by round-off: " << face_round_off << " of " << faces);
  // Interior elements: the seed's reference S = 4 r^2 (alpha(6) = 4 exactly).
  CHECK(s[static_cast<std::size_t>(L.id(1, 1, 1))] == 4.0 * r * r);

  // The tolerance decides e = 0.4 up to tol; beyond tol below 0.4 it is 1.
  CHECK(model.eccentricity_factor(0.4) == 2.0);
  CHECK(model.eccentricity_factor(0.4 - 1e-12) == 2.0);
  CHECK(model.eccentricity_factor(0.4 - 1e-6) == 1.0);
  CHECK(TransmissionSurfaceModel::platonic(0.0).eccentricity_factor(std::nextafter(0.4, 0.0)) == 1.0);

  // The alpha(n) and f_v(n) table of cohesive-joule-torsion.md §3.3: exact Platonic points
  // (1e-14), interpolated/extrapolated entries as printed (3-4 digits: 6e-4 absolute).
  CHECK(relative_error(model.alpha(4), 6.0 * std::sqrt(3.0)) < 1e-14);
  CHECK(model.alpha(6) == 4.0);
  CHECK(relative_error(model.alpha(8), 1.5 * std::sqrt(3.0)) < 1e-14);
  const int nn[] = {3, 5, 7, 9, 10, 11, 12, 20};
  const double alpha_note[] = {13.588, 7.196, 3.299, 2.295, 1.993, 1.690, 1.388, 0.758};
  const double fv_note[] = {0.192, 0.413, 0.564, 0.642, 0.680, 0.717, 0.7547, 0.8288};
  for (int k = 0; k < 8; ++k) {
    INFO("n = " << nn[k]);
    CHECK(std::abs(model.alpha(nn[k]) - alpha_note[k]) < 6e-4);
    CHECK(std::abs(model.volume_fraction_table(nn[k]) - fv_note[k]) < 6e-4);
  }
  CHECK(relative_error(model.volume_fraction_table(6), kPiT / 6.0) < 1e-14);
  // Clamping n to [3, 20].
  CHECK(model.alpha(0) == model.alpha(3));
  CHECK(model.alpha(1) == model.alpha(3));
  CHECK(model.alpha(35) == model.alpha(20));
  // f_v,i = f(e) f_v(n) (multiplied, as the seed says).
  CHECK(model.volume_fraction(5, 0.4) == 2.0 * model.volume_fraction_table(5));
  CHECK(model.volume_fraction(6, 0.0) == model.volume_fraction_table(6));

  // Model validation.
  const PiecewiseLinear ok({4.0, 6.0}, {10.0, 4.0});
  CHECK_THROWS_AS(PiecewiseLinear({4.0, 4.0}, {1.0, 2.0}), ConfigError);
  CHECK_THROWS_AS(PiecewiseLinear({6.0, 4.0}, {1.0, 2.0}), ConfigError);
  CHECK_THROWS_AS(PiecewiseLinear({4.0}, {1.0}), ConfigError);
  // alpha extrapolated to n = 20 from (4, 10), (6, 4) is negative: rejected.
  CHECK_THROWS_AS(TransmissionSurfaceModel(ok, ok, 3.0, 20.0, 0.4, 1e-9, 2.0), ConfigError);
  CHECK_NOTHROW(TransmissionSurfaceModel(ok, ok, 3.0, 7.0, 0.4, 1e-9, 2.0));
  CHECK_THROWS_AS(TransmissionSurfaceModel(ok, ok, 3.0, 7.0, 0.4, -1.0, 2.0), ConfigError);
  // Isolated node: n = 0, e = 0.
  const std::vector<Vec3> x2 = {Vec3::Zero(), Vec3(1, 0, 0), Vec3(5, 0, 0)};
  const std::vector<double> r2 = {0.5, 0.5, 0.5};
  const std::vector<Index> a2 = {0}, b2 = {1};
  CHECK(eccentricities(x2, r2, a2, b2)[2] == 0.0);
  CHECK(coordination_numbers(3, a2, b2)[2] == 0);
  CHECK(relative_error(eccentricities(x2, r2, a2, b2)[0], 2.0) < 1e-15);  // one neighbour at 2r
}

TEST_CASE("Transmission surface: lattice of columns gives R = rho l / A", "[electrical][conductance]") {
  // cohesive-joule-torsion.md §3.4: S = 4 r^2 for every element, an n x n array of columns of m
  // touching spheres between two electrode planes through the end centres: every branch is
  // rho (2r)/(4 r^2); each column is m - 1 branches in series, the n^2 columns are in parallel:
  // R = rho l / A, l = 2 r (m - 1), A = (2 r n)^2. Tolerance 1e-12 relative (m n^2 additions).
  const double rho = 1.6e-7;  // [Ohm m]
  struct Case {
    int n, m;
    double r;
  };
  for (const Case c : {Case{1, 2, 1e-3}, Case{3, 5, 50e-6}, Case{4, 10, 78e-6}, Case{7, 13, 2e-5}}) {
    INFO("n = " << c.n << ", m = " << c.m);
    const Lattice L = cubic_lattice(c.n, c.n, c.m, c.r, Vec3(0.0123, 0.456, -0.0789));
    double g_total = 0.0;
    for (int j = 0; j < c.n; ++j)
      for (int i = 0; i < c.n; ++i) {
        double r_col = 0.0;
        for (int k = 0; k + 1 < c.m; ++k) {
          const Vec3& p = L.x[static_cast<std::size_t>(L.id(i, j, k))];
          const Vec3& q = L.x[static_cast<std::size_t>(L.id(i, j, k + 1))];
          r_col += transmission_resistance(rho, (q - p).norm(), 4.0 * c.r * c.r, 4.0 * c.r * c.r);
        }
        g_total += 1.0 / r_col;
      }
    const double ell = 2.0 * c.r * (c.m - 1), area = std::pow(2.0 * c.r * c.n, 2);
    CHECK(relative_error(1.0 / g_total, rho * ell / area) < 1e-12);
  }
  // One branch: R = rho l / sqrt(S_i S_j), and the conductance is its inverse (1e-15).
  CHECK(relative_error(transmission_resistance(rho, 3e-5, 2e-10, 8e-10), rho * 3e-5 / 4e-10) < 1e-15);
  CHECK(relative_error(transmission_conductance(rho, 3e-5, 2e-10, 8e-10), 4e-10 / (rho * 3e-5)) < 1e-15);
  CHECK_THROWS_AS(transmission_resistance(rho, 0.0, 1e-10, 1e-10), ConfigError);
  CHECK_THROWS_AS(transmission_resistance(rho, 1e-5, 0.0, 1e-10), ConfigError);
}

TEST_CASE("Touching on/off and tunnelling with a cut-off", "[electrical][conductance]") {
  // Touching (seed 002): unit conductance iff overlap >= -tol (exact comparisons).
  const double tol = 1e-3 * 2e-6;  // 0.1 % of D = 2 um
  CHECK(touching_conductance(1e-7, tol) == 1.0);
  CHECK(touching_conductance(0.0, tol) == 1.0);
  CHECK(touching_conductance(-tol, tol) == 1.0);
  CHECK(touching_conductance(-std::nextafter(tol, 1.0), tol) == 0.0);
  CHECK(touching_conductance(-1e-6, tol) == 0.0);
  CHECK(touching_conductance(0.0, 0.0, 2.5) == 2.5);
  CHECK_THROWS_AS(touching_conductance(0.0, -1e-9), ConfigError);

  // Tunnelling: g0 exp(-2 gap/xi) (1e-14 relative), contact value for overlaps, 0 beyond cut-off.
  const double g0 = 1e-3, xi = 1e-9, cut = 5e-9;
  CHECK(tunnelling_conductance(0.0, g0, xi, cut) == g0);
  CHECK(tunnelling_conductance(-2e-9, g0, xi, cut) == g0);
  CHECK(relative_error(tunnelling_conductance(xi, g0, xi, cut), g0 * std::exp(-2.0)) < 1e-14);
  CHECK(relative_error(tunnelling_conductance(2.7e-9, g0, xi, cut), g0 * std::exp(-5.4)) < 1e-14);
  CHECK(relative_error(tunnelling_conductance(cut, g0, xi, cut), g0 * std::exp(-10.0)) < 1e-14);  // cut-off included
  CHECK(tunnelling_conductance(std::nextafter(cut, 1.0), g0, xi, cut) == 0.0);
  CHECK(tunnelling_conductance(1e-6, g0, xi, cut) == 0.0);
  CHECK(relative_error(tunnelling_conductance(20e-9, g0, xi, kInf), g0 * std::exp(-40.0)) < 1e-14);  // no cut-off
  // Ratio of two gaps: exp(-2 (g2 - g1)/xi) (1e-13).
  CHECK(relative_error(tunnelling_conductance(3e-9, g0, xi, cut) / tunnelling_conductance(1e-9, g0, xi, cut), std::exp(-4.0)) < 1e-13);
  CHECK_THROWS_AS(tunnelling_conductance(1e-9, g0, 0.0, cut), ConfigError);
  CHECK_THROWS_AS(tunnelling_conductance(1e-9, g0, xi, -1.0), ConfigError);
}

TEST_CASE("Bulk conductivity kappa(T): linear resistivity and tabulated", "[electrical][conductance]") {
  // Linear resistivity (copper-like): kappa(T_ref) = kappa_ref exactly; kappa = kappa_ref/(1 + beta dT)
  // (1e-14); the resistivity 1/kappa is linear in T: equal steps give equal differences (1e-12).
  const LinearResistivityLaw cu{5.8e7, 3.9e-3, 293.15};
  CHECK(conductivity(cu, 293.15) == 5.8e7);
  CHECK(relative_error(conductivity(cu, 393.15), 5.8e7 / (1.0 + 0.39)) < 1e-14);
  const double r1 = 1.0 / conductivity(cu, 300.0), r2 = 1.0 / conductivity(cu, 500.0), r3 = 1.0 / conductivity(cu, 700.0);
  CHECK(relative_error(r3 - r2, r2 - r1) < 1e-12);
  CHECK(relative_error((r2 - r1) / 200.0, 3.9e-3 / 5.8e7) < 1e-12);
  // beta = 0: constant.
  CHECK(conductivity(LinearResistivityLaw{1e6, 0.0, 293.15}, 1500.0) == 1e6);
  // 1 + beta (T - T_ref) <= 0 is outside the law: 1 + 3.9e-3 (T - 293.15) = 0 at T = 36.74 K.
  CHECK_THROWS_AS(conductivity(cu, 30.0), ConfigError);
  CHECK_THROWS_AS(conductivity(LinearResistivityLaw{0.0, 3.9e-3, 293.15}, 300.0), ConfigError);
  CHECK_THROWS_AS(conductivity(cu, std::nan("")), ConfigError);
  CHECK_THROWS_AS(conductivity(cu, -5.0), ConfigError);

  // Table: exact at the points, linear in between (1e-14), clamped beyond the ends (exact).
  const ConductivityTable t({300.0, 600.0, 1000.0}, {9.8e6, 6.0e6, 4.0e6});
  const ConductivityLaw law = t;
  CHECK(conductivity(law, 300.0) == 9.8e6);
  CHECK(conductivity(law, 600.0) == 6.0e6);
  CHECK(relative_error(conductivity(law, 450.0), 7.9e6) < 1e-14);
  CHECK(relative_error(conductivity(law, 900.0), 4.5e6) < 1e-14);
  CHECK(conductivity(law, 250.0) == 9.8e6);
  CHECK(conductivity(law, 1500.0) == 4.0e6);
  // Strict checks: T must increase strictly; kappa > 0; at least two points; T finite.
  CHECK_THROWS_AS(ConductivityTable({300.0, 300.0}, {1.0, 2.0}), ConfigError);
  CHECK_THROWS_AS(ConductivityTable({300.0, 600.0, 500.0}, {1.0, 2.0, 3.0}), ConfigError);
  CHECK_THROWS_AS(ConductivityTable({300.0, 600.0}, {1.0, 0.0}), ConfigError);
  CHECK_THROWS_AS(ConductivityTable({300.0, 600.0}, {1.0}), ConfigError);
  CHECK_THROWS_AS(ConductivityTable({300.0}, {1.0}), ConfigError);
  CHECK_THROWS_AS(ConductivityTable({300.0, kInf}, {1.0, 2.0}), ConfigError);
  CHECK_THROWS_AS(conductivity(law, std::nan("")), ConfigError);
}

}  // namespace test_conductance_kernels
