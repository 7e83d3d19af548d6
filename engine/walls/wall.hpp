#pragma once
/// Walls: shapes (std::variant) with a scalar offset u(t) along their inward normal.
///   plane:    point = point0 + u * normal          (normal points into the particle domain)
///   cylinder: radius = radius0 - u                  (particles inside; u > 0 contracts)
/// The wall velocity at a contact is u_dot * n, with n the inward normal at the contact.
/// Motions: fixed; constant speed (optionally limited travel); displacement table; or pressure
/// control (servo on the normal force: a punch driven to a target pressure, as in a hot press).
/// Prescribed motions are evaluated from the stage time (step * dt), never accumulated; only the
/// servo integrates u, and its state is in the checkpoint. Tables (displacement and pressure)
/// marked `physical_time` (every table a scenario gives) are in physical seconds from the stage
/// start and are read at t_phys = time_scale * t_stage (StageConfig::time_scale); speeds, the
/// servo speed limit and u_dot stay in mechanical time.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/error.hpp"
#include "engine/core/types.hpp"

namespace sparkdem {

struct PlaneShape {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();  ///< unit, into the domain
};
struct CylinderShape {
  Vec3 base = Vec3::Zero();   ///< a point on the axis
  Vec3 axis = Vec3::UnitZ();  ///< unit axis
  double radius = 1.0;        ///< [m] at u = 0
};
using WallShape = std::variant<PlaneShape, CylinderShape>;

struct WallMotion {
  enum class Kind { Fixed, Velocity, Table, Pressure };
  Kind kind = Kind::Fixed;
  double speed = 0.0;                                       ///< [m/s] along the inward normal (Velocity)
  double travel = std::numeric_limits<double>::infinity();  ///< [m] max |u - u_start| (Velocity)
  std::vector<double> table_time;                           ///< [s] from stage start (Table), physical if physical_time
  std::vector<double> table_disp;                           ///< [m] displacement from u_start (Table)
  std::vector<double> pressure_time;                        ///< [s] (Pressure) piecewise-linear target, physical if physical_time
  std::vector<double> pressure_value;                       ///< [Pa]
  double area = 0.0;                                        ///< [m^2] area the pressure acts on (0 = from the enclosing cylinder)
  double max_speed = 0.0;                                   ///< [m/s] servo speed limit
  bool physical_time = false;                               ///< table times are physical seconds (read at time_scale * t_stage)
  std::string halt_quantity;                                ///< stop the wall for good once this monitor column ...
  double halt_value = 0.0;                                  ///< ... reaches at least this value (checked with `until`)
};

struct Wall {
  std::string name;
  WallShape shape;
  WallMotion motion;
  double u = 0.0;             ///< current offset [m]
  double u_dot = 0.0;         ///< current offset rate [m/s]
  double u_start = 0.0;       ///< offset at the start of the current motion [m]
  Vec3 force = Vec3::Zero();  ///< total force of the particles on the wall [N]
  double normal_force = 0.0;  ///< component of `force` against the inward normal (push) [N]
  bool halted = false;        ///< the motion's halt condition was met: the wall stays where it is
  /// Work of the wall's load on the particles since the run began [J]: the sum over steps of the
  /// load times the step's offset increment, sum F (u' - u) (a punch pressing a compact does
  /// positive work). F is the normal force of the last force pass, except for a pressure wall,
  /// where it is the applied load p(t) A: its servo retracts while the force overshoots and
  /// advances while it lags, and summing that jitter with the measured force counted the servo's
  /// own oscillation as (negative) work, -9e-5 J against +3e-5 J of compaction in the main
  /// scenario. The quasi-static gate of a press compares the kinetic energy with it.
  double work = 0.0;

  bool is_plane() const { return std::holds_alternative<PlaneShape>(shape); }
  /// Inward normal at a particle centre x and signed distance from the wall to x (> 0 inside).
  void distance(const Vec3& x, Vec3& n, double& d) const {
    if (const auto* p = std::get_if<PlaneShape>(&shape)) {
      n = p->normal;
      d = p->normal.dot(x - p->point) - u;
    } else {
      const auto& c = std::get<CylinderShape>(shape);
      const Vec3 rel = x - c.base;
      const Vec3 radial = rel - c.axis.dot(rel) * c.axis;
      const double rho = radial.norm();
      n = rho > 0.0 ? Vec3(-radial / rho) : Vec3(Vec3::UnitX());
      d = (c.radius - u) - rho;
    }
  }
  double cylinder_radius() const { return std::get<CylinderShape>(shape).radius - u; }

  /// Shape and offset state (motions come from the stage configuration).
  void visit(Archive& ar, const std::string& prefix) {
    std::string kind = is_plane() ? "plane" : "cylinder";
    ar.visit(prefix + "/kind", kind);
    std::vector<double> g;
    if (!ar.reading()) {
      if (const auto* p = std::get_if<PlaneShape>(&shape))
        g = {p->point[0], p->point[1], p->point[2], p->normal[0], p->normal[1], p->normal[2], 0.0};
      else {
        const auto& c = std::get<CylinderShape>(shape);
        g = {c.base[0], c.base[1], c.base[2], c.axis[0], c.axis[1], c.axis[2], c.radius};
      }
    }
    ar.visit(prefix + "/geometry", g, 7);
    if (ar.reading()) {
      // A checkpoint is an input: check what it holds before using it.
      if (g.size() != 7)
        throw SetupError("checkpoint wall '" + name + "': geometry has " + std::to_string(g.size()) + " values, expected 7");
      for (double x : g)
        if (!std::isfinite(x)) throw SetupError("checkpoint wall '" + name + "': geometry holds a non-finite value");
      if (kind == "plane")
        shape = PlaneShape{Vec3(g[0], g[1], g[2]), Vec3(g[3], g[4], g[5])};
      else if (kind == "cylinder")
        shape = CylinderShape{Vec3(g[0], g[1], g[2]), Vec3(g[3], g[4], g[5]), g[6]};
      else
        throw SetupError("checkpoint wall '" + name + "': unknown kind '" + kind + "' (expected plane or cylinder)");
    }
    ar.visit(prefix + "/u", u);
    ar.visit(prefix + "/u_dot", u_dot);
    ar.visit(prefix + "/u_start", u_start);
    std::vector<Vec3> f{force};
    ar.visit(prefix + "/force", f);
    if (f.size() != 1) throw SetupError("checkpoint wall '" + name + "': force has " + std::to_string(f.size()) + " rows, expected 1");
    force = f[0];
    ar.visit(prefix + "/normal_force", normal_force);
    ar.visit(prefix + "/halted", halted);
    if (!ar.reading() || ar.has(prefix + "/work")) ar.visit(prefix + "/work", work);  // absent before issue 36: 0
  }
};

/// Piecewise-linear interpolation, clamped at both ends.
inline double interpolate(const std::vector<double>& t, const std::vector<double>& v, double x) {
  if (t.empty()) return 0.0;
  if (x <= t.front()) return v.front();
  if (x >= t.back()) return v.back();
  std::size_t k = 1;
  while (t[k] < x) ++k;
  const double s = (x - t[k - 1]) / (t[k] - t[k - 1]);
  return v[k - 1] + s * (v[k] - v[k - 1]);
}

/// The load [N] a pressure-controlled wall presses with at stage time t_stage: p(s t) A, with A the
/// motion's area or else `area_hint` (the die cross-section), s = time_scale for tables in physical time.
inline double pressure_load(const Wall& w, double t_stage, double area_hint, double time_scale = 1.0) {
  const WallMotion& m = w.motion;
  const double s = m.physical_time ? time_scale : 1.0;
  return interpolate(m.pressure_time, m.pressure_value, s * t_stage) * (m.area > 0.0 ? m.area : area_hint);
}

/// Update u and u_dot at stage time t_stage (prescribed) or by one servo step dt (pressure).
/// `area_hint` is used when a pressure motion has area 0 (the die cross-section). `time_scale`
/// (physical seconds per mechanical second) converts t_stage for tables in physical time:
///   table:    u = u_start + D(s t),  u_dot = (D(s (t + dt)) - D(s t)) / dt   (mechanical rate)
///   pressure: F_target = p(s t) A
/// with s = time_scale when motion.physical_time, else 1.
/// Returns the load that does the step's work (Wall::work): the target p A of a pressure wall,
/// else the normal force of the last force pass.
inline double advance_wall(Wall& w, double t_stage, double dt, double area_hint, double time_scale = 1.0) {
  const WallMotion& m = w.motion;
  const double s = m.physical_time ? time_scale : 1.0;
  if (w.halted) {
    w.u_dot = 0.0;
    return w.normal_force;
  }
  switch (m.kind) {
    case WallMotion::Kind::Fixed:
      w.u = w.u_start;
      w.u_dot = 0.0;
      break;
    case WallMotion::Kind::Velocity: {
      const double disp = m.speed * t_stage;
      if (std::abs(disp) >= m.travel) {
        w.u = w.u_start + std::copysign(m.travel, m.speed);
        w.u_dot = 0.0;
      } else {
        w.u = w.u_start + disp;
        w.u_dot = m.speed;
      }
      break;
    }
    case WallMotion::Kind::Table: {
      w.u = w.u_start + interpolate(m.table_time, m.table_disp, s * t_stage);
      const double h = dt;
      w.u_dot = (interpolate(m.table_time, m.table_disp, s * (t_stage + h)) - interpolate(m.table_time, m.table_disp, s * t_stage)) / h;
      break;
    }
    case WallMotion::Kind::Pressure: {
      const double target = pressure_load(w, t_stage, area_hint, time_scale);
      double ratio = target > 0.0 ? (target - w.normal_force) / target : -1.0;
      ratio = std::clamp(ratio, -1.0, 1.0);
      w.u_dot = m.max_speed * ratio;
      w.u += w.u_dot * dt;
      return target;
    }
  }
  return w.normal_force;
}

/// Move a plane wall along its normal so that the nearest of the given spheres' surfaces is `gap`
/// [m] away (a punch put on top of a packing). No-op for a cylinder or no spheres.
inline void place_plane_at_clearance(Wall& w, const std::vector<Vec3>& centres, const std::vector<double>& radii, double gap) {
  if (!w.is_plane() || centres.empty()) return;
  double nearest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < centres.size(); ++i) {
    Vec3 n;
    double d;
    w.distance(centres[i], n, d);
    nearest = std::min(nearest, d - radii[i]);
  }
  auto& plane = std::get<PlaneShape>(w.shape);
  plane.point += (nearest - gap) * plane.normal;
}

}  // namespace sparkdem
