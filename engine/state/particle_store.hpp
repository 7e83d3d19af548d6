#pragma once
/// Particle store: fixed core SoA arrays plus a FieldRegistry for optional fields.
#include <cmath>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/types.hpp"
#include "engine/state/field_registry.hpp"

namespace sparkdem {

struct ParticleStore {
  std::vector<Id> id;
  std::vector<Vec3> position;          ///< [m]
  std::vector<Vec3> velocity;          ///< [m/s]
  std::vector<Quat> orientation;       ///< unit quaternion
  std::vector<Vec3> omega;             ///< angular velocity [rad/s]
  std::vector<Vec3> force;             ///< [N]
  std::vector<Vec3> torque;            ///< [N m]
  std::vector<double> radius;          ///< [m]
  std::vector<double> mass;            ///< [kg] (includes mass scaling when enabled)
  std::vector<double> inertia;         ///< moment of inertia of the sphere [kg m^2]
  std::vector<std::int32_t> material;  ///< index into the material table
  std::vector<std::int32_t> fixed;     ///< 1 = not integrated (frozen particle)
  FieldRegistry fields;                ///< optional per-particle fields

  std::size_t size() const { return id.size(); }
  /// Mean radius [m] (0 for no particle).
  double mean_radius() const {
    double sum = 0.0;
    for (double r : radius) sum += r;
    return radius.empty() ? 0.0 : sum / static_cast<double>(radius.size());
  }
  Id next_id = 0;

  /// Append one particle at rest; returns its local index.
  Index add(const Vec3& x, double r, double m, std::int32_t mat = 0) {
    id.push_back(next_id++);
    position.push_back(x);
    velocity.push_back(Vec3::Zero());
    orientation.push_back(Quat::Identity());
    omega.push_back(Vec3::Zero());
    force.push_back(Vec3::Zero());
    torque.push_back(Vec3::Zero());
    radius.push_back(r);
    mass.push_back(m);
    inertia.push_back(0.4 * m * r * r);
    material.push_back(mat);
    fixed.push_back(0);
    fields.resize(size());
    return static_cast<Index>(size() - 1);
  }

  /// Reorder: new[i] = old[perm[i]] for every core array and every registered field.
  void permute(const std::vector<Index>& perm) {
    apply(id, perm);
    apply(position, perm);
    apply(velocity, perm);
    apply(orientation, perm);
    apply(omega, perm);
    apply(force, perm);
    apply(torque, perm);
    apply(radius, perm);
    apply(mass, perm);
    apply(inertia, perm);
    apply(material, perm);
    apply(fixed, perm);
    fields.permute(perm);
  }

  /// Keep only the particles with keep[i] true (order preserved).
  void filter(const std::vector<bool>& keep) {
    std::vector<Index> perm;
    for (std::size_t i = 0; i < keep.size(); ++i)
      if (keep[i]) perm.push_back(static_cast<Index>(i));
    permute(perm);
  }

  void visit(Archive& ar, const std::string& prefix) {
    std::vector<std::int64_t> ids(id.begin(), id.end());
    ar.visit(prefix + "/id", ids);
    if (ar.reading()) id.assign(ids.begin(), ids.end());
    ar.visit(prefix + "/position", position);
    ar.visit(prefix + "/velocity", velocity);
    ar.visit(prefix + "/orientation", orientation);
    ar.visit(prefix + "/omega", omega);
    ar.visit(prefix + "/force", force);
    ar.visit(prefix + "/torque", torque);
    ar.visit(prefix + "/radius", radius);
    ar.visit(prefix + "/mass", mass);
    ar.visit(prefix + "/inertia", inertia);
    ar.visit(prefix + "/material", material);
    ar.visit(prefix + "/fixed", fixed);
    std::int64_t nid = next_id;
    ar.visit(prefix + "/next_id", nid);
    next_id = nid;
    if (ar.reading()) fields.resize(size());
    fields.visit(ar, prefix + "/fields");
    if (ar.reading()) check_restored();
  }

  /// After reading a checkpoint: every array has one row per particle, and the values a run
  /// can never produce (non-finite kinematics, radius/mass/inertia not > 0, negative material
  /// index) are rejected. Throws SetupError.
  void check_restored() const {
    const std::size_t n = id.size();
    auto rows = [&](const char* what, std::size_t m) {
      if (m != n)
        throw SetupError(std::string("checkpoint particle array '") + what + "' has " + std::to_string(m) + " rows for " +
                         std::to_string(n) + " particle ids");
    };
    rows("position", position.size());
    rows("velocity", velocity.size());
    rows("orientation", orientation.size());
    rows("omega", omega.size());
    rows("force", force.size());
    rows("torque", torque.size());
    rows("radius", radius.size());
    rows("mass", mass.size());
    rows("inertia", inertia.size());
    rows("material", material.size());
    rows("fixed", fixed.size());
    for (const auto& name : fields.names()) {
      const std::size_t c = static_cast<std::size_t>(fields.info(name).components);
      if (fields.data(name).size() != n * c)
        throw SetupError("checkpoint particle field '" + name + "' has " + std::to_string(fields.data(name).size()) + " values, expected " +
                         std::to_string(n) + " x " + std::to_string(c));
    }
    for (std::size_t i = 0; i < n; ++i) {
      const bool finite = position[i].allFinite() && velocity[i].allFinite() && omega[i].allFinite() && force[i].allFinite() &&
                          torque[i].allFinite() && orientation[i].coeffs().allFinite();
      if (!finite || !(radius[i] > 0.0) || !std::isfinite(radius[i]) || !(mass[i] > 0.0) || !std::isfinite(mass[i]) ||
          !(inertia[i] > 0.0) || !std::isfinite(inertia[i]) || material[i] < 0)
        throw SetupError("checkpoint particle " + std::to_string(id[i]) + " (row " + std::to_string(i) +
                         ") holds values no run produces (non-finite position, velocity, spin, force or orientation, "
                         "radius, mass or inertia not > 0, or a negative material index)");
    }
  }

 private:
  template <class T>
  static void apply(std::vector<T>& v, const std::vector<Index>& perm) {
    std::vector<T> out(perm.size());
    for (std::size_t i = 0; i < perm.size(); ++i) out[i] = v[perm[i]];
    v.swap(out);
  }
};

}  // namespace sparkdem
