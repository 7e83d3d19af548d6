#pragma once
/// Helpers to build small States in code and to watch a stage step by step.
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "engine/simulation.hpp"
#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::test {

/// Mass of a sphere of radius r [m] and density rho [kg/m^3].
inline double sphere_mass(double r, double rho) { return 4.0 / 3.0 * std::numbers::pi * r * r * r * rho; }

/// Add a sphere of density rho with velocity v; returns its local index.
inline Index add_sphere(State& s, const Vec3& x, double r, double rho, const Vec3& v = Vec3::Zero()) {
  const Index i = s.particles.add(x, r, sphere_mass(r, rho));
  s.particles.velocity[i] = v;
  return i;
}

/// Assign the particle set `name` to the particles with these global ids (SetSelector Ids);
/// returns the member count.
inline std::size_t id_set(State& s, const std::string& name, std::vector<Id> ids) {
  SetSelector sel;
  sel.kind = SetSelector::Kind::Ids;
  sel.ids = std::move(ids);
  return assign_set(s, name, sel);
}

/// A fixed plane wall through `point` with inward unit normal `normal`.
inline Wall plane_wall(const std::string& name, const Vec3& point, const Vec3& normal) {
  Wall w;
  w.name = name;
  w.shape = PlaneShape{point, normal.normalized()};
  return w;
}

/// The six walls of the box [lo, hi], normals pointing inside.
inline void add_box(State& s, const Vec3& lo, const Vec3& hi) {
  const char* axis = "xyz";
  for (int d = 0; d < 3; ++d) {
    Vec3 n = Vec3::Zero();
    n[d] = 1.0;
    s.walls.push_back(plane_wall(std::string(1, axis[d]) + "_lo", lo, n));
    s.walls.push_back(plane_wall(std::string(1, axis[d]) + "_hi", hi, -n));
  }
}

/// A stage with a fixed step, a step budget and a skin; observer callback on every step and no
/// time-series sampling (tests compute what they need from the State).
inline StageConfig stage(double dt, Step steps, double skin = 0.0) {
  StageConfig c;
  c.dt = dt;
  c.max_steps = steps;
  c.skin = skin;
  c.timeseries_every = 0;
  c.log_every = 1;
  return c;
}

/// The same with the mechanics frozen (only the coupling modules run; StageConfig::mechanics).
inline StageConfig frozen_stage(double dt, Step steps) {
  StageConfig c = stage(dt, steps);
  c.mechanics = false;
  return c;
}

/// Observer that ignores everything.
class NullObserver : public Observer {};

/// Observer that calls `on_step(state, stage_steps)` after every `log_every`-th step.
class StepObserver : public Observer {
 public:
  explicit StepObserver(std::function<void(const State&, Step)> f) : on_step_(std::move(f)) {}
  void progress(const State& s, Step stage_steps, double, double) override { on_step_(s, stage_steps); }

 private:
  std::function<void(const State&, Step)> on_step_;
};

/// Local index of the particle with global id `id` (-1 if absent).
inline Index local_index(const ParticleStore& p, Id id) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.id[i] == id) return static_cast<Index>(i);
  return -1;
}

/// n radii log-uniform in [rmin, rmin * ratio] (the first two are set to the two bounds so the
/// full ratio is always present) and random positions in a cube [0, L]^3 sized so that the
/// spheres' total volume is the fraction `phi` of the cube (overlaps allowed). Returns L.
inline double random_polydisperse(std::size_t n, double rmin, double ratio, double phi, std::uint64_t seed, std::vector<Vec3>& x,
                                  std::vector<double>& r) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  r.resize(n);
  double vol = 0.0;
  for (std::size_t i = 0; i < n; ++i) r[i] = rmin * std::pow(ratio, u(rng));
  if (n > 1) {
    r[0] = rmin;
    r[1] = rmin * ratio;
  }
  for (double ri : r) vol += 4.0 / 3.0 * std::numbers::pi * ri * ri * ri;
  const double box = std::cbrt(vol / phi);
  x.resize(n);
  for (auto& xi : x) xi = Vec3(u(rng), u(rng), u(rng)) * box;
  return box;
}

}  // namespace sparkdem::test
