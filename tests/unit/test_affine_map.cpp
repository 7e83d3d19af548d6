// apply_affine_scale (engine/state/affine_map.hpp): positions and walls follow x -> o + S (x - o);
// radii do not; a plane keeps its offset u and its surface maps; a cylinder's current radius scales
// by the factor across its axis; walls it cannot map are refused.
#include <catch2/catch.hpp>

#include "engine/core/error.hpp"
#include "engine/state/affine_map.hpp"
#include "tests/support/scene.hpp"

namespace test_affine_map {

using namespace sparkdem;

TEST_CASE("affine map: a compact in its die densified isotropically and uniaxially", "[affine][state]") {
  State s;
  test::add_sphere(s, Vec3(1e-3, 2e-3, 3e-3), 0.5e-3, 5910.0);
  test::add_sphere(s, Vec3(-2e-3, 0.0, 8e-3), 0.7e-3, 5910.0);
  Wall die;
  die.name = "die";
  die.shape = CylinderShape{Vec3(0.5e-3, 0.5e-3, 0.0), Vec3::UnitZ(), 5e-3};
  die.u = 0.4e-3;  // current radius 4.6 mm
  s.walls.push_back(die);
  s.walls.push_back(test::plane_wall("bottom", Vec3(0, 0, 1e-3), Vec3::UnitZ()));
  s.walls.back().u = 0.2e-3;  // surface at z = 1.2 mm
  s.walls.push_back(test::plane_wall("top", Vec3(0, 0, 12e-3), -Vec3::UnitZ()));
  s.walls.back().u = 1e-3;  // surface at z = 11 mm
  const Vec3 o(0.5e-3, 0.5e-3, 1.2e-3), S(0.9, 0.9, 0.8);
  const std::vector<Vec3> x0 = s.particles.position;
  apply_affine_scale(s, o, S);
  for (std::size_t i = 0; i < x0.size(); ++i) CHECK((s.particles.position[i] - (o + S.cwiseProduct(x0[i] - o))).norm() <= 1e-14 * 1e-3);
  CHECK(std::abs(s.particles.radius[0] - 0.5e-3) <= 0.0);  // radii are not mapped
  CHECK(std::abs(s.walls[0].cylinder_radius() - 0.9 * 4.6e-3) <= 1e-14 * 1e-3);
  CHECK(std::abs(s.walls[0].u - 0.4e-3) <= 0.0);  // the offset is kept
  const auto surface = [&](int k) {
    const auto& p = std::get<PlaneShape>(s.walls[static_cast<std::size_t>(k)].shape);
    return (p.point + s.walls[static_cast<std::size_t>(k)].u * p.normal).z();
  };
  CHECK(std::abs(surface(1) - 1.2e-3) <= 1e-14 * 1e-3);                        // on the fixed point
  CHECK(std::abs(surface(2) - (1.2e-3 + 0.8 * (11e-3 - 1.2e-3))) <= 1e-14 * 1e-3);  // heights x 0.8
  // The signed distance of every particle to every wall scales with the map across that wall.
  Vec3 n;
  double d;
  s.walls[2].distance(s.particles.position[1], n, d);
  CHECK(std::abs(d - 0.8 * (11e-3 - 8e-3)) <= 1e-15);
  CHECK(s.wall_candidates.empty());
}

TEST_CASE("affine map: walls it cannot map and scales that are not > 0 are refused", "[affine][state]") {
  State s;
  test::add_sphere(s, Vec3::Zero(), 1e-3, 5910.0);
  s.walls.push_back(test::plane_wall("tilted", Vec3::Zero(), Vec3(1, 1, 0).normalized()));
  CHECK_THROWS_AS(apply_affine_scale(s, Vec3::Zero(), Vec3(0.9, 0.9, 1.0)), SetupError);
  // An isotropic map takes any plane: its surface point maps and the particle keeps its distance x s.
  Vec3 n;
  double before, after;
  s.walls[0].distance(Vec3(1e-3, 0.0, 0.0), n, before);
  CHECK_NOTHROW(apply_affine_scale(s, Vec3::Zero(), Vec3(0.9, 0.9, 0.9)));
  s.walls[0].distance(Vec3(0.9e-3, 0.0, 0.0), n, after);
  CHECK(std::abs(after - 0.9 * before) <= 1e-17);
  s.walls.clear();
  Wall die;
  die.name = "die";
  die.shape = CylinderShape{Vec3::Zero(), Vec3::UnitZ(), 5e-3};
  s.walls.push_back(die);
  CHECK_THROWS_AS(apply_affine_scale(s, Vec3::Zero(), Vec3(0.9, 0.8, 1.0)), SetupError);
  CHECK_THROWS_AS(apply_affine_scale(s, Vec3::Zero(), Vec3(0.0, 1.0, 1.0)), SetupError);
}

}  // namespace test_affine_map
