/// torsion_test's resistance onsets through the persistence filter (issue 20 step 4), driven by a
/// scripted resistance signal against a scripted twist of a two-element pin: the twisted end is
/// turned to theta_k = k x 1 mrad and R/R0 follows a script with a spike that falls back (the crack
/// halves rattling), a sustained 1.5 x rise, a jump to 3 x and the separation (R < 0: no path).
/// Expected by construction of the script: unfiltered, the rise and jump onsets are the spike's
/// first twist; with a persistence of 10 mrad the spike is rejected (counted once for each
/// condition) and the onsets are the twists where the sustained rise, the jump and the separation
/// began.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>
#include <vector>

#include "engine/state/state.hpp"
#include "physics/mechanics/resistance_trend.hpp"
#include "physics/mechanics/torsion_test.hpp"
#include "tests/support/scene.hpp"

namespace test_torsion_filter {

using namespace sparkdem;

namespace {
struct Script {
  double rise_onset, jump_onset, separation, rejected_rises, rejected_jumps;
};

/// R/R0 at twist step k (theta = k mrad).
double scripted_ratio(int k) {
  if (k >= 30 && k < 34) return 2.5;  // spike: falls back after 4 mrad
  if (k >= 90) return -1.0;           // separated: the network reports R < 0 (no path)
  if (k >= 70) return 3.0;            // doubled
  if (k >= 50) return 1.5;            // sustained rise
  return 1.0 + 1e-4 * k;              // elastic drift, below the 1 % threshold
}

/// A two-element pin (bottom and top sets, one sphere each) and the torsion_test parameters of
/// its scripts, resistance read from signal "R".
physics::TorsionTest::Params two_element_pin(State& s) {
  test::add_sphere(s, Vec3(0, 0, 0), 1e-4, 7000.0);
  test::add_sphere(s, Vec3(0, 0, 2e-4), 1e-4, 7000.0);
  test::id_set(s, "bottom", {s.particles.id[0]});
  test::id_set(s, "top", {s.particles.id[1]});
  physics::TorsionTest::Params p;
  p.radius = 1e-4;
  p.shear_modulus = 1e10;
  p.yield_shear_stress = 1e8;
  p.resistance_signal = "R";
  return p;
}

/// The value of column `name` among the module's columns.
double column(const std::vector<std::string>& cols, const std::vector<double>& v, const std::string& name) {
  for (std::size_t i = 0; i < cols.size(); ++i)
    if (cols[i] == name) return v[i];
  FAIL("no column " << name);
  return 0.0;
}

Script run_script(double persistence) {
  State s;
  physics::TorsionTest::Params p = two_element_pin(s);
  p.resistance_persistence = persistence;
  physics::TorsionTest t(p);
  const double R0 = 2.0;  // [Ohm]
  t.bind(s);
  std::vector<double> v;
  for (int k = 0; k <= 110; ++k) {
    const double theta = 1e-3 * k;
    s.particles.orientation[1] = Quat(Eigen::AngleAxisd(theta, Vec3::UnitZ()));
    const double ratio = scripted_ratio(k);
    s.marks["signal/R"] = ratio < 0.0 ? -1.0 : ratio * R0;
    t.advance(s, StepInfo{k, 0.0, 0.0});
  }
  const auto cols = t.columns();
  v = t.column_values(s);
  auto col = [&](const std::string& n) { return column(cols, v, n); };
  return {col("torsion_resistance_onset_twist"), col("torsion_resistance_jump_twist"), col("torsion_separation_twist"),
          col("torsion_resistance_rejected_rises"), col("torsion_resistance_rejected_jumps")};
}
}  // namespace

TEST_CASE("torsion_test resistance onsets: unfiltered first crossing; a persistence span rejects a spike that falls back",
          "[torsion][electrical]") {
  const Script raw = run_script(0.0);
  CHECK(raw.rise_onset == Approx(0.030).epsilon(1e-9));
  CHECK(raw.jump_onset == Approx(0.030).epsilon(1e-9));
  CHECK(raw.separation == Approx(0.090).epsilon(1e-9));
  CHECK(raw.rejected_rises == 0.0);  // unfiltered: the first crossing is final, nothing is rejected
  const Script f = run_script(0.010);
  CHECK(f.rise_onset == Approx(0.050).epsilon(1e-9));
  CHECK(f.jump_onset == Approx(0.070).epsilon(1e-9));
  CHECK(f.separation == Approx(0.090).epsilon(1e-9));
  CHECK(f.rejected_rises == 1.0);
  CHECK(f.rejected_jumps == 1.0);
}

namespace {
/// The trend onset on a scripted R/R0: an elastic quadratic drift 1 + 0.3 theta^2 with a
/// deterministic +-1e-7 ripple, held for 5 calls at each value (a re-solve every 5 steps), and
/// from step `rise_at` (twist rise_at x 0.1 mrad; < 0: never) a jump `jump`, and from step
/// `slope_from` (< 0: rise_at) a rise of 2e-5 per mrad. Returns (onset, samples, departure
/// at the last call) from the module's columns.
struct TrendResult {
  double onset, samples, departure;
};

TrendResult run_trend(int rise_at, double jump = 1e-5, int slope_from = -1) {
  State s;
  physics::TorsionTest::Params p = two_element_pin(s);
  p.resistance_persistence = 1e-3;
  p.resistance_trend_fit_twist = 0.02;
  p.resistance_trend_sigmas = 5.0;
  p.resistance_trend_floor = 1e-6;
  physics::TorsionTest t(p);
  t.bind(s);
  double ratio = 1.0;
  for (int k = 0; k <= 900; ++k) {  // theta = k x 0.1 mrad, to 0.09 rad
    const double theta = 1e-4 * k;
    s.particles.orientation[1] = Quat(Eigen::AngleAxisd(theta, Vec3::UnitZ()));
    if (k % 5 == 0) {
      const double ripple = ((k / 5) % 2 == 0 ? 1.0 : -1.0) * 1e-7;
      ratio = 1.0 + 0.3 * theta * theta + (k == 0 ? 0.0 : ripple);
      if (rise_at >= 0 && k >= rise_at) ratio += jump;
      const int from = slope_from >= 0 ? slope_from : rise_at;
      if (from >= 0 && k >= from) ratio += 2e-2 * 1e-4 * (k - from);
    }
    s.marks["signal/R"] = 2.0 * ratio;
    t.advance(s, StepInfo{k, 0.0, 0.0});
  }
  const auto cols = t.columns();
  const auto v = t.column_values(s);
  auto col = [&](const std::string& n) { return column(cols, v, n); };
  return {col("torsion_resistance_trend_onset_twist"), col("torsion_resistance_trend_samples"),
          col("torsion_resistance_trend_departure")};
}
}  // namespace

TEST_CASE("torsion_test trend onset: no detection on an elastic drift, the first rise above the trend otherwise",
          "[torsion][electrical]") {
  // Elastic only: the quadratic drift is the trend; the ripple is the fit's noise (sigma about
  // 1e-7): the departure stays below the threshold (5 sigma + 1e-6) out to 4.5 x the fit span.
  const TrendResult elastic = run_trend(-1);
  CHECK(std::isnan(elastic.onset));
  CHECK(elastic.samples == 41.0);  // one sample per held value up to 0.02 rad (k = 0, 5, ..., 200)
  CHECK(std::abs(elastic.departure) < 1.0);
  // A rise from 0.04 rad: 1e-5 at once, then 2e-5 per mrad, above the 1.5e-6 threshold at once.
  const TrendResult cracked = run_trend(400);
  CHECK(cracked.onset == Approx(0.04).epsilon(1e-9));  // the first twist of the rise (step 400)
  CHECK(cracked.departure > 100.0);
  // A drop of 1e-5 from 0.04 rad (a broken bond that widens its elements' other branches) and a
  // rise only from 0.06 rad: detected at the drop.
  const TrendResult dropped = run_trend(400, -1e-5, 600);
  CHECK(dropped.onset == Approx(0.04).epsilon(1e-9));
  CHECK(dropped.departure > 100.0);
}

TEST_CASE("resistance trend kernel: the quadratic and its residual deviation are exact on exact data", "[torsion]") {
  physics::trend::Sums t;
  for (int k = 0; k < 10; ++k) {
    const double x = 0.1 * k;
    t.add(x, 1e-3 + 2e-3 * x - 5e-4 * x * x);
  }
  const auto f = physics::trend::fit(t);
  REQUIRE(f.valid);
  CHECK(f.c[0] == Approx(1e-3).epsilon(1e-9));
  CHECK(f.c[1] == Approx(2e-3).epsilon(1e-9));
  CHECK(f.c[2] == Approx(-5e-4).epsilon(1e-9));
  CHECK(f.sigma < 1e-9);
  // Fewer than six samples: no trend.
  physics::trend::Sums few;
  for (int k = 0; k < 5; ++k) few.add(0.1 * k, 0.0);
  CHECK_FALSE(physics::trend::fit(few).valid);
}

}  // namespace test_torsion_filter
