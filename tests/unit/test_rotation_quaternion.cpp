// The orientation update of the integrator (engine/integrate/velocity_verlet.hpp) against the
// closed form: the rotation by angle |w| dt about w is the quaternion (cos(|w| dt/2),
// sin(|w| dt/2) w/|w|) (Eigen's AngleAxis builds it from sin and cos), and composing unit
// quaternions keeps unit length.
#include <catch2/catch.hpp>

#include <cmath>

#include "engine/integrate/velocity_verlet.hpp"

namespace test_rotation_quaternion {

using namespace sparkdem;

namespace {
Quat closed_form(const Vec3& w, double dt) {
  const double a = w.norm() * dt;
  return Quat(Eigen::AngleAxisd(a, w / w.norm()));
}
}  // namespace

TEST_CASE("rotation_quaternion equals the angle-axis quaternion on both branches", "[integrate]") {
  const double dt = 1e-5;
  // |w| dt / 2 from 1e-12 to 0.5: the series branch (below 1e-2) and the sin/cos branch.
  for (const double h : {1e-12, 1e-6, 1e-3, 9.9e-3, 1.01e-2, 0.1, 0.5}) {
    const Vec3 w = Vec3(0.3, -0.8, 0.52).normalized() * (2.0 * h / dt);
    const Quat q = rotation_quaternion(w, w.squaredNorm(), dt), ref = closed_form(w, dt);
    INFO("h = " << h);
    for (int k = 0; k < 4; ++k) CHECK(std::abs(q.coeffs()[k] - ref.coeffs()[k]) <= 4e-16);
  }
}

TEST_CASE("renormalised keeps a spinning orientation at unit length over 1e6 steps", "[integrate]") {
  const Vec3 w(120.0, -45.0, 310.0);  // rad/s; h = |w| dt / 2 = 1.7e-3: the series branch
  const double dt = 1e-5;
  const Quat step = rotation_quaternion(w, w.squaredNorm(), dt);
  Quat q = Quat::Identity();
  for (int n = 0; n < 1000000; ++n) q = renormalised(step * q);
  CHECK(std::abs(q.coeffs().norm() - 1.0) <= 1e-14);
  // The angle turned, 1e6 |w| dt, against the closed form (the rounding of 1e6 products).
  const Quat ref = closed_form(w, 1e6 * dt);
  CHECK(std::abs(std::abs(q.dot(ref)) - 1.0) <= 1e-10);
}

}  // namespace test_rotation_quaternion
