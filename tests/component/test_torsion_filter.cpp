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

Script run_script(double persistence) {
  State s;
  test::add_sphere(s, Vec3(0, 0, 0), 1e-4, 7000.0);
  test::add_sphere(s, Vec3(0, 0, 2e-4), 1e-4, 7000.0);
  test::id_set(s, "bottom", {s.particles.id[0]});
  test::id_set(s, "top", {s.particles.id[1]});
  physics::TorsionTest::Params p;
  p.radius = 1e-4;
  p.shear_modulus = 1e10;
  p.yield_shear_stress = 1e8;
  p.resistance_signal = "R";
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
  auto col = [&](const std::string& n) {
    for (std::size_t i = 0; i < cols.size(); ++i)
      if (cols[i] == n) return v[i];
    FAIL("no column " << n);
    return 0.0;
  };
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

}  // namespace test_torsion_filter
