#pragma once
/// # gravity — uniform body force F_i = m_i g
/// (With mass scaling the scaled mass is used, so scaled particles fall with the same g.)
///
/// | parameter    | unit  | meaning                         |
/// |--------------|-------|---------------------------------|
/// | acceleration | m/s^2 | gravitational acceleration g    |
#include <cmath>
#include <string>

#include "engine/core/error.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/state/state.hpp"
#include "engine/core/parallel.hpp"

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
  void declare(Declarations& d) const override {
    d.writes = {"force"};
    d.reads = {"mass"};
  }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const std::int64_t n = static_cast<std::int64_t>(p.size());
    // Local pointers and a local g: stores through p.force would otherwise reload them per particle.
    par::region(par::worth(n, par::kLight), [&] {
      Vec3* __restrict f = p.force.data();
      const double* __restrict m = p.mass.data();
      const Vec3 g = p_.acceleration;
#pragma omp for schedule(static) nowait
      for (std::int64_t i = 0; i < n; ++i) f[i] += m[i] * g;
    });
  }

 private:
  Params p_;
};

/// # viscous_damping — background drag F_i = -c m_i v_i, T_i = -c I_i w_i
/// A numerical aid for quasi-static packing and relaxation stages (reported, off by default).
/// Prescribed particles (fixed != 0) are skipped, so their force stays the reaction of the sample.
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
  void declare(Declarations& d) const override {
    d.writes = {"force"};
    d.reads = {"velocity"};
  }
  double stable_dt(const State&) const override { return p_.rate > 0.0 ? 2.0 / p_.rate : std::numeric_limits<double>::infinity(); }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const std::int64_t n = static_cast<std::int64_t>(p.size());
    par::for_each(n, par::kLight, [&](std::int64_t i) {
      if (p.fixed[i]) return;  // prescribed: its force is a reported reaction, not integrated
      p.force[i] -= p_.rate * p.mass[i] * p.velocity[i];
      p.torque[i] -= p_.rate * p.inertia[i] * p.omega[i];
    });
  }

 private:
  Params p_;
};

/// # local_damping — Cundall's local non-viscous damping (PFC, YADE `NewtonIntegrator.damping`)
///   F_i,k <- F_i,k - alpha |F_i,k| sign(v_i,k),  T_i,k <- T_i,k - alpha |T_i,k| sign(w_i,k)  (k = x, y, z)
/// Source: P.A. Cundall, "Distinct element models of rock and soil structure" (1987); YADE docs.
/// Removes a fraction alpha of the work of the unbalanced force in every half oscillation; it damps
/// only accelerating motion, so a quasi-static state (zero net force) is not biased. A numerical
/// aid for quasi-static stages, off unless listed. It acts on the net force: list it after every
/// other force module of the stage (force modules run in the listed order, after contacts and bonds).
/// Prescribed and frozen particles (fixed != 0) are skipped: their force is a reported reaction
/// (set_<name>_fz, _tz, tension_test), which a damping term of up to alpha |F| would falsify.
class LocalDamping final : public Module {
 public:
  struct Params {
    double coefficient = 0.7;  ///< alpha [1]
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("local_damping", "module", "Cundall local damping F -= alpha |F| sign(v) per component (list it last)");
    s.add("coefficient", &Params::coefficient).unit("1").range(0.0, 1.0).doc("alpha, fraction of the unbalanced force removed");
    return s;
  }
  explicit LocalDamping(const Params& p) : p_(p) {}
  std::string name() const override { return "local_damping"; }
  void declare(Declarations& d) const override {
    d.writes = {"force", "torque"};
    d.reads = {"velocity", "omega"};
  }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const std::int64_t n = static_cast<std::int64_t>(p.size());
    auto sign = [](double x) { return x > 0.0 ? 1.0 : x < 0.0 ? -1.0 : 0.0; };
    par::for_each(n, par::kLight, [&](std::int64_t i) {
      // A prescribed (or frozen) particle is not integrated: its force is the reaction of the
      // rest of the system (set_<name>_f*, tension_test), which damping must not alter.
      if (p.fixed[i]) return;
      for (int k = 0; k < 3; ++k) {
        p.force[i][k] -= p_.coefficient * std::abs(p.force[i][k]) * sign(p.velocity[i][k]);
        p.torque[i][k] -= p_.coefficient * std::abs(p.torque[i][k]) * sign(p.omega[i][k]);
      }
    });
  }

 private:
  Params p_;
};

/// # add_force — a constant external force and torque on every member of a particle set
/// (LAMMPS `fix addforce` on a group): F_i += force, T_i += torque for i in the set.
class AddForce final : public Module {
 public:
  struct Params {
    std::string set;
    Vec3 force = Vec3::Zero();   ///< [N] per member
    Vec3 torque = Vec3::Zero();  ///< [N m] per member
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("add_force", "module", "constant force and torque on each member of a particle set");
    s.add("set", &Params::set).required().doc("particle set (listed in the stage's \"sets\")");
    s.add_vec3("force", &Params::force).unit("N").doc("force on each member");
    s.add_vec3("torque", &Params::torque).unit("N m").doc("torque on each member");
    return s;
  }
  explicit AddForce(const Params& p) : p_(p) {}
  std::string name() const override { return "add_force"; }
  void declare(Declarations& d) const override { d.writes = {"force", "torque"}; }
  void bind(State& s) override {
    if (!s.particles.fields.has("set/" + p_.set))
      throw SetupError("add_force: particle set '" + p_.set + "' is not defined (list it in the stage's \"sets\")");
  }
  void advance(State& s, const StepInfo&) override {
    auto& p = s.particles;
    const auto& f = p.fields.data("set/" + p_.set);
    for (std::size_t i = 0; i < p.size(); ++i)
      if (f[i] > 0.5) {
        p.force[i] += p_.force;
        p.torque[i] += p_.torque;
      }
  }

 private:
  Params p_;
};

}  // namespace sparkdem::physics
