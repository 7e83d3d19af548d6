/// The "necks" stage key (physics/packing/neck_statistics.hpp): the statistics against hand
/// counts, and the monitor on a state whose contact rows hold known neck radii.
#include <catch2/catch.hpp>

#include <cmath>

#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "physics/contact/sintering.hpp"
#include "physics/packing/neck_statistics.hpp"
#include "support/scene.hpp"

namespace test_neck_statistics {

using namespace sparkdem;
using namespace sparkdem::physics;

TEST_CASE("neck statistics: count, median and histogram bins of a / r_min", "[necks][packing]") {
  // Ten bins on [0, 1]: 0.05 -> bin 0; 0.95 and 1.0 -> bin 9 (x = 1 in the last bin); 0.31,
  // 0.33, 0.35 -> bin 3. Seven values: median 0.33; fullest bin 3/7; last bin 2/7.
  const NeckStatistics s = neck_statistics({0.95, 0.05, 0.33, 1.0, 0.31, 0.35, 0.6}, 10);
  CHECK(s.necks == 7.0);
  CHECK(s.median == 0.35);
  CHECK(s.max_bin_percent == Approx(100.0 * 3.0 / 7.0).epsilon(1e-15));
  CHECK(s.last_bin_percent == Approx(100.0 * 2.0 / 7.0).epsilon(1e-15));
  // Even count: the mean of the two middle values.
  CHECK(neck_statistics({0.1, 0.4, 0.2, 0.3}, 10).median == Approx(0.25).epsilon(1e-15));
  // No neck: 0 and NaN.
  const NeckStatistics e = neck_statistics({}, 10);
  CHECK(e.necks == 0.0);
  CHECK(std::isnan(e.median));
  CHECK(std::isnan(e.max_bin_percent));
}

TEST_CASE("necks monitor: reads the law's neck_radius column, r_min of each pair", "[necks][packing]") {
  // Three spheres on a line (r = 1, 2, 1 um) overlapping by 0.02 um: two hot sintering contacts,
  // each with the Kratos neck of its overlap about r_min = 1 um (their x equal). A law without
  // a neck column: no neck.
  State s;
  const double h = 0.02e-6;
  test::add_sphere(s, Vec3(0, 0, 0), 1e-6, 5900.0);
  test::add_sphere(s, Vec3(3e-6 - h, 0, 0), 2e-6, 5900.0);
  test::add_sphere(s, Vec3(6e-6 - 2 * h, 0, 0), 1e-6, 5900.0);
  Sintering::Params p;
  p.temperature = 1500.0;
  p.sintering_start_temperature = 1000.0;
  p.min_neck_fraction = 1e-3;
  const ContactModelT<Sintering> law(p);
  Simulation sim(s, law);
  test::NullObserver obs;
  sim.run_stage(test::stage(1e-15, 1, 0.5e-6), obs);
  REQUIRE(s.contacts.size() == 2);
  const NeckMonitor mon(NeckMonitor::Params{});
  CHECK(mon.columns(s) == std::vector<std::string>{"necks", "neck_median_a_over_rmin", "neck_max_bin_percent", "neck_last_bin_percent"});
  const auto v = mon.values(s);
  const double x = kernel::kratos_neck_radius(1e-6, h) / 1e-6;
  CHECK(v[0] == 2.0);
  CHECK(v[1] == Approx(x).epsilon(1e-6));
  CHECK(v[2] == 100.0);
  CHECK(v[3] == 0.0);
}

}  // namespace test_neck_statistics
