#include "io/scenario/scenario_parts.hpp"

#include <cmath>
#include <limits>

namespace sparkdem::io {

namespace {

struct WallParams {
  std::string name;
  std::string type = "plane";
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  Vec3 base = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0;
  double clearance = -1.0;
};
ParamSpec<WallParams> wall_spec() {
  ParamSpec<WallParams> s("wall", "wall", "a plane (normal into the domain) or a cylinder (particles inside)");
  s.add("name", &WallParams::name).required().doc("unique wall name");
  s.add("type", &WallParams::type).choices({"plane", "cylinder"}).doc("shape");
  s.add_vec3("point", &WallParams::point).unit("m").doc("plane: a point on the plane");
  s.add_vec3("normal", &WallParams::normal).unit("1").doc("plane: normal pointing into the particle domain");
  s.add("clearance", &WallParams::clearance)
      .unit("m")
      .doc(
          "plane added by a stage: placed along its normal at this gap from the nearest particle surface at the stage start (e.g. a punch "
          "on a packing); < 0: at `point`");
  s.add_vec3("base", &WallParams::base).unit("m").doc("cylinder: a point on the axis");
  s.add_vec3("axis", &WallParams::axis).unit("1").doc("cylinder: axis direction");
  s.add("radius", &WallParams::radius).unit("m").nonnegative().doc("cylinder: radius");
  return s;
}
struct MotionParams {
  std::string type = "fixed";
  double speed = 0.0;
  double travel = std::numeric_limits<double>::infinity();
  std::vector<double> times, displacements, pressures;
  double area = 0.0;
  double max_speed = 0.0;
};
ParamSpec<MotionParams> motion_spec() {
  ParamSpec<MotionParams> s("motion", "motion",
                            "wall motion during a stage, as an offset u along the inward normal (plane) or a radius "
                            "decrease (cylinder)");
  s.add("type", &MotionParams::type).choices({"fixed", "velocity", "table", "pressure"}).doc("kind of motion");
  s.add("speed", &MotionParams::speed).unit("m/s").doc("velocity: du/dt (positive moves into the domain)");
  s.add("travel", &MotionParams::travel).unit("m").positive().doc("velocity: stop after this displacement");
  s.add("times", &MotionParams::times)
      .unit("s")
      .nonnegative()
      .doc("table/pressure: physical times from the stage start (stage time x time_scale; = stage time when time_scale is 1)");
  s.add("displacements", &MotionParams::displacements).unit("m").doc("table: displacement at each time");
  s.add("pressures", &MotionParams::pressures).unit("Pa").nonnegative().doc("pressure: target pressure at each time");
  s.add("area", &MotionParams::area).unit("m^2").nonnegative().doc("pressure: loaded area (0 = die cross-section)");
  s.add("max_speed", &MotionParams::max_speed).unit("m/s").nonnegative().doc("pressure: servo speed limit");
  return s;
}

/// A module clock: {"kind": every_step|every_n_steps|substeps|adaptive_substeps|on_event, "n",
/// and for on_event the trigger conditions}.
struct ClockParams {
  std::string kind = "every_step";
  std::int64_t n = 1;
  double moved_beyond = std::numeric_limits<double>::infinity();
  std::string field;
  double field_change = std::numeric_limits<double>::infinity();
  bool bond_broke = false;
  std::int64_t max_interval = 0;
};
ParamSpec<ClockParams> clock_spec() {
  using P = ClockParams;
  ParamSpec<P> s("clock", "object", "when a module runs relative to the mechanical step");
  s.add("kind", &P::kind)
      .choices({"every_step", "every_n_steps", "substeps", "adaptive_substeps", "on_event"})
      .doc(
          "every step; every n steps (dt = n dt_m); n substeps per step (dt = dt_m/n); adaptive substeps (at least n, more when the "
          "module's stable step shrinks); on an event");
  s.add("n", &P::n).min(1).doc("steps per call (every_n_steps) or (minimum) substeps per step");
  s.add("moved_beyond", &P::moved_beyond).unit("m").positive().doc("on_event: a particle moved more than this since the last call");
  s.add("field", &P::field).doc("on_event: particle field watched for changes");
  s.add("field_change", &P::field_change).positive().doc("on_event: change of `field` (its unit) that triggers a call");
  s.add("bond_broke", &P::bond_broke).doc("on_event: a bond broke since the last call");
  s.add("max_interval", &P::max_interval).min(0).doc("on_event: also call after this many steps (0: never)");
  return s;
}

}  // namespace

std::string list_names(const std::vector<std::string>& n) {
  std::string s;
  for (const auto& x : n) s += (s.empty() ? "" : ", ") + x;
  return s;
}

std::unique_ptr<ContactModel> make_law(const json& c, const Registry& reg, const std::string& path, std::vector<Diagnostic>& errors,
                                       json& resolved) {
  return make_named(c, reg.laws(), "contact law", path, errors, resolved);
}

Spec wall_schema() { return wall_spec().spec(); }
Spec motion_schema() { return motion_spec().spec(); }
Spec clock_schema() { return clock_spec().spec(); }

Clock make_clock(const json& j, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const ClockParams p = build(clock_spec(), j, path, errors, resolved);
  Clock c;
  c.n = p.n;
  if (p.kind == "every_n_steps")
    c.kind = Clock::Kind::EveryNSteps;
  else if (p.kind == "substeps")
    c.kind = Clock::Kind::SubstepsPerStep;
  else if (p.kind == "adaptive_substeps")
    c.kind = Clock::Kind::AdaptiveSubsteps;
  else if (p.kind == "on_event")
    c.kind = Clock::Kind::OnEvent;
  c.trigger = {p.moved_beyond, p.field, p.field_change, p.bond_broke, p.max_interval};
  const bool event_keys = std::isfinite(p.moved_beyond) || !p.field.empty() || std::isfinite(p.field_change) || p.bond_broke ||
                          p.max_interval > 0;
  if (c.kind == Clock::Kind::OnEvent) {
    if (!(std::isfinite(p.moved_beyond) || (!p.field.empty() && std::isfinite(p.field_change)) || p.bond_broke || p.max_interval > 0))
      errors.push_back({path, "an on_event clock needs a condition: moved_beyond, field + field_change, bond_broke or max_interval"});
    if (p.field.empty() != !std::isfinite(p.field_change)) errors.push_back({path + "/field_change", "field and field_change go together"});
  } else if (event_keys) {
    errors.push_back({path + "/kind", "trigger conditions are given but kind is \"" + p.kind + "\", not \"on_event\""});
  }
  return c;
}

Wall make_wall(const json& w, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const WallParams p = build(wall_spec(), w, path, errors, resolved);
  Wall out;
  out.name = p.name;
  if (p.type == "plane") {
    if (p.normal.norm() == 0.0) errors.push_back({path + "/normal", "expected a non-zero normal, found [0, 0, 0]"});
    out.shape = PlaneShape{p.point, p.normal.norm() > 0 ? Vec3(p.normal.normalized()) : Vec3(Vec3::UnitZ())};
  } else {
    if (p.axis.norm() == 0.0) errors.push_back({path + "/axis", "expected a non-zero axis, found [0, 0, 0]"});
    if (!(p.radius > 0.0)) errors.push_back({path + "/radius", "a cylinder needs a radius > 0 [m], found " + std::to_string(p.radius)});
    out.shape = CylinderShape{p.base, p.axis.norm() > 0 ? Vec3(p.axis.normalized()) : Vec3(Vec3::UnitZ()), p.radius};
  }
  return out;
}

WallMotion make_motion(const json& m, const std::string& path, std::vector<Diagnostic>& errors, json& resolved) {
  const MotionParams p = build(motion_spec(), m, path, errors, resolved);
  WallMotion out;
  out.physical_time = true;  // tables in physical seconds, like the physical-time modules
  if (p.type == "fixed") out.kind = WallMotion::Kind::Fixed;
  if (p.type == "velocity") {
    out.kind = WallMotion::Kind::Velocity;
    out.speed = p.speed;
    out.travel = p.travel;
  }
  auto check_table = [&](const std::vector<double>& values, const char* key) {
    if (p.times.empty()) errors.push_back({path + "/times", std::string("a ") + p.type + " motion needs `times`, found none"});
    if (values.size() != p.times.size())
      errors.push_back({path + "/" + key,
                        "expected " + std::to_string(p.times.size()) + " values (one per time), found " + std::to_string(values.size())});
    for (std::size_t k = 1; k < p.times.size(); ++k)
      if (!(p.times[k] > p.times[k - 1])) errors.push_back({path + "/times/" + std::to_string(k), "times must increase strictly"});
  };
  if (p.type == "table") {
    out.kind = WallMotion::Kind::Table;
    check_table(p.displacements, "displacements");
    out.table_time = p.times;
    out.table_disp = p.displacements;
  }
  if (p.type == "pressure") {
    out.kind = WallMotion::Kind::Pressure;
    check_table(p.pressures, "pressures");
    if (!(p.max_speed > 0.0)) errors.push_back({path + "/max_speed", "a pressure motion needs max_speed > 0 [m/s]"});
    out.pressure_time = p.times;
    out.pressure_value = p.pressures;
    out.area = p.area;
    out.max_speed = p.max_speed;
  }
  return out;
}

}  // namespace sparkdem::io
