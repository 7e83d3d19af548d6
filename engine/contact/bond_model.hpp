#pragma once
/// The ONE generic bond loop, instantiated per bond law (BondModelT<Law>), and its type-erased
/// handle, mirroring ContactModel. A bond law sees the current geometry of the pair and the
/// world images of the reference directions taken at bonding (BondReference), and returns the
/// force on i, the torques on i and j, and whether the bond broke in this step.
///
/// A BondLaw provides:
///   static constexpr std::string_view kName;  struct Params;  static ParamSpec<Params> spec();
///   static std::vector<std::string> state_columns();
///   explicit Law(const Params&);
///   BondForces operator()(const BondGeometry&, const BondMotion&, double dt, double* state) const;
///   BondStiffness stiffness(const BondGeometry&) const;   // for the stable step
/// and optionally (detected with `requires`):
///   double energy(const BondGeometry&, const double* state) const;          // elastic energy [J]
///   double failure_stress(const BondGeometry&, const double* state) const;  // criterion value [Pa]
///   static std::vector<std::string> failure_modes();  // names of BondForces::mode 1, 2, ...
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/state/bond_table.hpp"
#include "engine/state/particle_store.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

struct BondGeometry {
  Vec3 n;                       ///< unit vector j -> i (current)
  double distance = 0.0;        ///< current centre distance [m]
  double length0 = 0.0;         ///< centre distance at bonding [m]
  double r_i = 0.0, r_j = 0.0;  ///< radii [m]
  Vec3 dir_i, dir_j;            ///< world images of the reference directions i->j and j->i (BondReference)
  Vec3 perp_i, perp_j;          ///< world images of the reference normal vector in i's and j's frames
};

struct BondMotion {
  Vec3 v_ij;              ///< v_i - v_j [m/s]
  Vec3 omega_i, omega_j;  ///< [rad/s]
};

struct BondForces {
  Vec3 force = Vec3::Zero();     ///< on i (j gets minus) [N]
  Vec3 torque_i = Vec3::Zero();  ///< [N m]
  Vec3 torque_j = Vec3::Zero();  ///< [N m]
  bool broken = false;           ///< the bond failed in this step (forces of this step still apply)
  std::uint8_t mode = 0;         ///< failure mode when broken (1-based index into the law's failure_modes())
};

/// A bond that broke in a force pass: its row and failure mode.
struct BondFailure {
  std::size_t row = 0;
  std::uint8_t mode = 0;
};

/// Stiffnesses of one bond for the stable-step bound.
struct BondStiffness {
  double axial = 0.0;    ///< [N/m]
  double shear = 0.0;    ///< [N/m]
  double bending = 0.0;  ///< [N m/rad]
  double torsion = 0.0;  ///< [N m/rad]
};

class BondModel {
 public:
  virtual ~BondModel() = default;
  virtual std::string name() const = 0;
  virtual std::vector<std::string> state_columns() const = 0;
  /// Fill the per-row forces of intact bonds; returns the rows that broke in this pass
  /// (in row order), which the caller marks broken and hands to the contact table.
  virtual std::vector<BondFailure> pass(const ParticleStore& p, BondTable& b, double dt) const = 0;
  /// Names of the failure modes (BondFailure::mode 1, 2, ...); empty if the law has none.
  virtual std::vector<std::string> failure_modes() const = 0;
  /// Elastic energy stored in the intact bonds [J] (0 if the law does not define it).
  virtual double elastic_energy(const ParticleStore& p, const BondTable& b) const = 0;
  /// Largest failure-criterion stress over the intact bonds [Pa] (NaN if the law has none).
  virtual double max_failure_stress(const ParticleStore& p, const BondTable& b) const = 0;
  /// Add each intact bond's contribution to the per-particle Gershgorin rows of the
  /// mass-weighted stiffness matrix [1/s^2] (see ContactModel::stable_dt):
  ///   translation: (k_a + k_s) (1/m_i + 1/sqrt(m_i m_j))
  ///   rotation:    (k_b + k_t + k_s L^2/4) (1/I_i + 1/sqrt(I_i I_j))
  /// each plus the shear-rotation coupling c = k_s L / 2 (1/sqrt(m_i I_i) + 1/sqrt(m_i I_j), resp.
  /// 1/sqrt(I_i m_i) + 1/sqrt(I_i m_j)), and the larger of the two goes into the particle's row.
  /// For two equal spheres joined by a cohesive beam (r_mu = r/2) this gives 0.81 of the exact
  /// critical step 2/omega_max of the 12-dof system (test_cohesive_beam.cpp measures it).
  virtual void add_stiffness_rows(const ParticleStore& p, const BondTable& b, std::vector<double>& rows) const = 0;
};

namespace detail {
inline BondGeometry bond_geometry(const ParticleStore& p, const BondTable& b, std::size_t r) {
  const Index i = b.i(r), j = b.j(r);
  const BondReference& ref = b.reference(r);
  BondGeometry g;
  const Vec3 d = p.position[i] - p.position[j];
  g.distance = d.norm();
  g.n = g.distance > 0.0 ? Vec3(d / g.distance) : Vec3(Vec3::UnitX());
  g.length0 = ref.length0;
  g.r_i = p.radius[i];
  g.r_j = p.radius[j];
  g.dir_i = p.orientation[i] * ref.dir_i;
  g.dir_j = p.orientation[j] * ref.dir_j;
  g.perp_i = p.orientation[i] * ref.perp_i;
  g.perp_j = p.orientation[j] * ref.perp_j;
  return g;
}
}  // namespace detail

template <class Law>
class BondModelT final : public BondModel {
 public:
  explicit BondModelT(const typename Law::Params& params) : law_(params) {}
  const Law& law() const { return law_; }
  std::string name() const override { return std::string(Law::kName); }
  std::vector<std::string> state_columns() const override { return Law::state_columns(); }

  std::vector<BondFailure> pass(const ParticleStore& p, BondTable& b, double dt) const override {
    const std::int64_t rows = static_cast<std::int64_t>(b.size());
    auto& F = b.force();
    auto& Ti = b.torque_i();
    auto& Tj = b.torque_j();
    std::vector<std::uint8_t> broke(b.size(), 0);
    par::for_each(rows, par::kHeavy, [&](std::int64_t r) {
      if (b.broken(r)) {
        F[r].setZero();
        Ti[r].setZero();
        Tj[r].setZero();
        return;
      }
      const Index i = b.i(r), j = b.j(r);
      const BondGeometry g = detail::bond_geometry(p, b, r);
      const BondMotion m{p.velocity[i] - p.velocity[j], p.omega[i], p.omega[j]};
      const BondForces f = law_(g, m, dt, b.state(r));
      F[r] = f.force;
      Ti[r] = f.torque_i;
      Tj[r] = f.torque_j;
      broke[r] = f.broken ? std::max<std::uint8_t>(f.mode, 1) : 0;
    });
    std::vector<BondFailure> out;
    for (std::size_t r = 0; r < b.size(); ++r)
      if (broke[r]) out.push_back({r, broke[r]});
    return out;
  }

  std::vector<std::string> failure_modes() const override {
    if constexpr (requires { Law::failure_modes(); })
      return Law::failure_modes();
    else
      return {};
  }
  double elastic_energy(const ParticleStore& p, const BondTable& b) const override {
    if constexpr (requires(const Law& l, const BondGeometry& g, const double* st) { l.energy(g, st); }) {
      double u = 0.0;
      for (std::size_t r = 0; r < b.size(); ++r)
        if (!b.broken(r)) u += law_.energy(detail::bond_geometry(p, b, r), b.state(r));
      return u;
    } else {
      return 0.0;
    }
  }
  double max_failure_stress(const ParticleStore& p, const BondTable& b) const override {
    if constexpr (requires(const Law& l, const BondGeometry& g, const double* st) { l.failure_stress(g, st); }) {
      double m = 0.0;
      for (std::size_t r = 0; r < b.size(); ++r)
        if (!b.broken(r)) m = std::max(m, law_.failure_stress(detail::bond_geometry(p, b, r), b.state(r)));
      return m;
    } else {
      return std::numeric_limits<double>::quiet_NaN();
    }
  }

  void add_stiffness_rows(const ParticleStore& p, const BondTable& b, std::vector<double>& rows) const override {
    for (std::size_t r = 0; r < b.size(); ++r) {
      if (b.broken(r)) continue;
      const Index i = b.i(r), j = b.j(r);
      const BondStiffness k = law_.stiffness(detail::bond_geometry(p, b, r));
      const double L = b.reference(r).length0;
      const double kt = k.axial + k.shear, kr = k.bending + k.torsion + k.shear * L * L / 4.0, c = k.shear * L / 2.0;
      const double mij = 1.0 / std::sqrt(p.mass[i] * p.mass[j]), iij = 1.0 / std::sqrt(p.inertia[i] * p.inertia[j]);
      // shear-rotation coupling c = k_s L / 2 (the 6 E I / L^2 of a beam) in both rows
      const double cij = 1.0 / std::sqrt(p.mass[i] * p.inertia[j]), cji = 1.0 / std::sqrt(p.mass[j] * p.inertia[i]);
      const double ci = 1.0 / std::sqrt(p.mass[i] * p.inertia[i]), cj = 1.0 / std::sqrt(p.mass[j] * p.inertia[j]);
      rows[i] += std::max(kt * (1.0 / p.mass[i] + mij) + c * (ci + cij), kr * (1.0 / p.inertia[i] + iij) + c * (ci + cji));
      rows[j] += std::max(kt * (1.0 / p.mass[j] + mij) + c * (cj + cji), kr * (1.0 / p.inertia[j] + iij) + c * (cj + cij));
    }
  }

 private:
  Law law_;
};

}  // namespace sparkdem
