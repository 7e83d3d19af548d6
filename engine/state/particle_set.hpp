#pragma once
/// Named particle sets for boundary conditions and outputs. A selector is evaluated on the
/// current state (at the start of the stage that first needs it) and its membership is stored
/// as the per-particle field "set/<name>" (1 = member), so it follows reorderings, appears in
/// the result frames and is part of checkpoints.
#include <string>
#include <vector>

#include "engine/state/state.hpp"

namespace sparkdem {

struct SetSelector {
  enum class Kind { TopLayer, BottomLayer, TouchingWall, Ids, Box, Cylinder };
  Kind kind = Kind::TopLayer;
  double thickness = 0.0;                     ///< [m] TopLayer/BottomLayer: centres within this height of the top/bottom centre
  std::string wall;                           ///< TouchingWall: wall name
  double tolerance = 0.0;                     ///< [m] TouchingWall: gap allowed between particle surface and wall
  std::vector<Id> ids;                        ///< Ids
  Vec3 lo = Vec3::Zero(), hi = Vec3::Zero();  ///< Box: centres inside [lo, hi] [m]
  /// Cylinder (infinite along its axis): the axis passes through `axis_point` [m] along `axis`
  /// (any non-zero length; normalised here). With `overlap` false a particle is a member when
  /// its centre lies within `radius` [m] of the axis (d <= radius); with `overlap` true when the
  /// sphere reaches into the cylinder (d < radius + r_i).
  Vec3 axis_point = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0;
  bool overlap = false;
};

/// Members (local indices) of the selector in the current state. Throws SetupError for an
/// unknown wall, and for a cylinder with a zero axis or a radius that is not positive.
inline std::vector<Index> select_particles(const State& s, const SetSelector& sel) {
  const auto& p = s.particles;
  std::vector<Index> out;
  if (p.size() == 0) return out;
  double zmin = p.position[0].z(), zmax = zmin;
  for (const auto& x : p.position) {
    zmin = std::min(zmin, x.z());
    zmax = std::max(zmax, x.z());
  }
  const Wall* wall = nullptr;
  if (sel.kind == SetSelector::Kind::TouchingWall) {
    for (const auto& w : s.walls)
      if (w.name == sel.wall) wall = &w;
    if (!wall) throw SetupError("particle set: no wall named '" + sel.wall + "' exists at this stage");
  }
  Vec3 axis = sel.axis;
  if (sel.kind == SetSelector::Kind::Cylinder) {
    if (!(axis.norm() > 0.0) || !axis.allFinite()) throw SetupError("particle set: a cylinder needs a non-zero axis direction");
    if (!(sel.radius > 0.0)) throw SetupError("particle set: a cylinder needs radius > 0 [m]");
    axis.normalize();
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    bool in = false;
    switch (sel.kind) {
      case SetSelector::Kind::TopLayer:
        in = p.position[i].z() >= zmax - sel.thickness;
        break;
      case SetSelector::Kind::BottomLayer:
        in = p.position[i].z() <= zmin + sel.thickness;
        break;
      case SetSelector::Kind::TouchingWall: {
        Vec3 n;
        double d;
        wall->distance(p.position[i], n, d);
        in = d <= p.radius[i] + sel.tolerance;
        break;
      }
      case SetSelector::Kind::Ids:
        in = std::find(sel.ids.begin(), sel.ids.end(), p.id[i]) != sel.ids.end();
        break;
      case SetSelector::Kind::Box:
        in = (p.position[i].array() >= sel.lo.array()).all() && (p.position[i].array() <= sel.hi.array()).all();
        break;
      case SetSelector::Kind::Cylinder: {
        const Vec3 rel = p.position[i] - sel.axis_point;
        const double d = (rel - rel.dot(axis) * axis).norm();  // distance of the centre from the axis
        in = sel.overlap ? d < sel.radius + p.radius[i] : d <= sel.radius;
        break;
      }
    }
    if (in) out.push_back(static_cast<Index>(i));
  }
  return out;
}

/// The field "set/<name>" (1 = member) of a particle set the stage lists in "sets"; SetupError
/// naming `module` when it does not.
inline const std::vector<double>& set_field(const State& s, const std::string& name, const std::string& module) {
  if (!s.particles.fields.has("set/" + name))
    throw SetupError(module + ": '" + name + "' is not a particle set of this stage (list it in the stage's \"sets\")");
  return s.particles.fields.data("set/" + name);
}

/// Indices of the members of a particle set the stage lists in "sets" (SetupError as set_field).
inline std::vector<Index> set_members(const State& s, const std::string& name, const std::string& module) {
  const auto& f = set_field(s, name, module);
  std::vector<Index> out;
  for (std::size_t i = 0; i < f.size(); ++i)
    if (f[i] > 0.5) out.push_back(static_cast<Index>(i));
  return out;
}

/// Evaluate the selector and store it as the field "set/<name>".
inline std::size_t assign_set(State& s, const std::string& name, const SetSelector& sel) {
  s.particles.fields.declare({"set/" + name, 1, "1", 0.0, true}, s.particles.size());
  auto& f = s.particles.fields.data("set/" + name);
  std::fill(f.begin(), f.end(), 0.0);
  const auto members = select_particles(s, sel);
  for (Index i : members) f[i] = 1.0;
  return members.size();
}

}  // namespace sparkdem
