#pragma once
/// # gravity — uniform body force F_i = m_i g
/// (With mass scaling the scaled mass is used, so scaled particles fall with the same g.)
///
/// | parameter    | unit  | meaning                         |
/// |--------------|-------|---------------------------------|
/// | acceleration | m/s^2 | gravitational acceleration g    |
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

class Gravity final : public Module {
 public:
  struct Params {
    Vec3 acceleration = Vec3(0.0, 0.0, -9.81);
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("gravity", "module", "uniform gravitational body force F = m g");
    s.add_vec3("acceleration", &Params::acceleration).unit("m/s^2").doc("gravitational acceleration vector");
    return s;
  }
  explicit Gravity(const Params& p) : p_(p) {}
  std::string name() const override { return "gravity"; }
  void declare(Declarations& d) const override { d.writes = {"force"}; d.reads = {"mass"}; }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const std::int64_t n = static_cast<std::int64_t>(p.size());
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i) p.force[i] += p.mass[i] * p_.acceleration;
  }

 private:
  Params p_;
};

/// # viscous_damping — background drag F_i = -c m_i v_i, T_i = -c I_i w_i
/// A numerical aid for quasi-static packing and relaxation stages (reported, off by default).
class ViscousDamping final : public Module {
 public:
  struct Params {
    double rate = 0.0;  ///< c [1/s]
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("viscous_damping", "module", "background drag F = -c m v, T = -c I w (numerical aid)");
    s.add("rate", &Params::rate).unit("1/s").nonnegative().doc("drag rate c");
    return s;
  }
  explicit ViscousDamping(const Params& p) : p_(p) {}
  std::string name() const override { return "viscous_damping"; }
  void declare(Declarations& d) const override { d.writes = {"force"}; d.reads = {"velocity"}; }
  double stable_dt(const State&) const override { return p_.rate > 0.0 ? 2.0 / p_.rate : std::numeric_limits<double>::infinity(); }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const std::int64_t n = static_cast<std::int64_t>(p.size());
#pragma omp parallel for schedule(static)
    for (std::int64_t i = 0; i < n; ++i) {
      p.force[i] -= p_.rate * p.mass[i] * p.velocity[i];
      p.torque[i] -= p_.rate * p.inertia[i] * p.omega[i];
    }
  }

 private:
  Params p_;
};

}  // namespace sparkdem::physics
