#include "engine/start_checks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"

namespace sparkdem {

namespace {

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

/// One pass over pairs and walls: fills the report's max ratio, worst contact and counts above
/// `limit`; with `corr` non-null also accumulates the relaxation corrections towards `target`
/// (ratio) per particle.
void scan(const State& s, double limit, InitialOverlapReport& rep, double target, std::vector<Vec3>* corr) {
  const auto& p = s.particles;
  rep.max_ratio = 0.0;
  rep.pairs_over_limit = rep.walls_over_limit = 0;
  rep.worst_i = rep.worst_j = -1;
  rep.worst_wall.clear();
  for (const auto& pr : find_pairs(p.position, p.radius, 0.0)) {
    const Index i = pr[0], j = pr[1];
    Vec3 d = p.position[i] - p.position[j];
    const double dist = d.norm();
    const double rmin = std::min(p.radius[i], p.radius[j]);
    const double delta = p.radius[i] + p.radius[j] - dist;
    if (!(delta > 0.0)) continue;
    const double ratio = delta / rmin;
    if (ratio > rep.max_ratio) {
      rep.max_ratio = ratio;
      rep.worst_i = std::min(p.id[i], p.id[j]);
      rep.worst_j = std::max(p.id[i], p.id[j]);
      rep.worst_wall.clear();
    }
    if (ratio > limit) ++rep.pairs_over_limit;
    if (corr && ratio > target) {
      // Coincident centres: separate along x (any direction resolves them).
      const Vec3 n = dist > 0.0 ? Vec3(d / dist) : Vec3(Vec3::UnitX());
      const double excess = delta - target * rmin;
      const bool fi = p.fixed[i] != 0, fj = p.fixed[j] != 0;
      if (fi && fj) continue;
      const double wi = fi ? 0.0 : fj ? 1.0 : 0.5;
      (*corr)[i] += wi * excess * n;
      (*corr)[j] -= (1.0 - wi) * excess * n;
    }
  }
  for (const Wall& w : s.walls) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      Vec3 n;
      double dist;
      w.distance(p.position[i], n, dist);
      const double delta = p.radius[i] - dist;
      if (!(delta > 0.0)) continue;
      const double ratio = delta / p.radius[i];
      if (ratio > rep.max_ratio) {
        rep.max_ratio = ratio;
        rep.worst_i = p.id[i];
        rep.worst_j = -1;
        rep.worst_wall = w.name;
      }
      if (ratio > limit) ++rep.walls_over_limit;
      if (corr && ratio > target && p.fixed[i] == 0) (*corr)[i] += (delta - target * p.radius[i]) * n;
    }
  }
}

std::string worst_text(const InitialOverlapReport& r) {
  if (r.worst_j >= 0)
    return "particles " + std::to_string(r.worst_i) + " and " + std::to_string(r.worst_j) + " overlap by " + fmt(r.max_ratio) +
           " of the smaller radius";
  return "particle " + std::to_string(r.worst_i) + " overlaps wall '" + r.worst_wall + "' by " + fmt(r.max_ratio) + " of its radius";
}

}  // namespace

InitialOverlapReport measure_initial_overlap(const State& s, double limit) {
  InitialOverlapReport r;
  r.limit = limit;
  scan(s, limit, r, 0.0, nullptr);
  r.max_ratio_after = r.max_ratio;
  return r;
}

InitialOverlapReport apply_initial_overlap_policy(State& s, const std::string& stage, const std::string& policy, double limit,
                                                  int max_sweeps) {
  InitialOverlapReport r = measure_initial_overlap(s, limit);
  r.policy = policy;
  if (policy == "allow" || r.max_ratio <= limit) return r;
  const std::size_t over = r.pairs_over_limit + r.walls_over_limit;
  const std::string where = "stage '" + stage + "': " + std::to_string(over) +
                            " initial overlap(s) above initial_overlap_limit = " + fmt(limit) + "; worst: " + worst_text(r);
  if (policy == "refuse")
    throw SetupError(where +
                     ". Separate the particles (a `relax` generator stage or a looser packing), set the stage's "
                     "\"initial_overlap\": \"relax\", or raise \"initial_overlap_limit\" (\"allow\" runs as is)");
  if (policy != "relax") throw SetupError("stage '" + stage + "': unknown initial_overlap policy '" + policy + "'");
  auto& p = s.particles;
  const std::vector<Vec3> x0 = p.position;
  std::vector<Vec3> corr(p.size());
  InitialOverlapReport cur = r;
  const double target = 0.5 * limit;
  while (cur.max_ratio > limit) {
    if (r.sweeps >= max_sweeps)
      throw SetupError("stage '" + stage + "': initial_overlap \"relax\" did not bring the overlaps below " + fmt(limit) + " in " +
                       std::to_string(max_sweeps) + " sweeps (worst now: " + worst_text(cur) +
                       "); the packing is too dense to be separated in place: start from a looser packing");
    std::fill(corr.begin(), corr.end(), Vec3::Zero());
    scan(s, limit, cur, target, &corr);
    if (cur.max_ratio <= limit) break;
    // Half the summed corrections: a particle pushed from two sides by equal amounts stays put
    // rather than being thrown by their sum.
    for (std::size_t i = 0; i < p.size(); ++i) p.position[i] += 0.5 * corr[i];
    ++r.sweeps;
  }
  r.max_ratio_after = cur.max_ratio;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double d = (p.position[i] - x0[i]).norm();
    if (d > 0.0) ++r.moved;
    r.max_displacement = std::max(r.max_displacement, d);
  }
  return r;
}

void check_pressure_walls(const State& s, const std::string& stage, const std::map<std::string, WallMotion>& motions) {
  for (const auto& [name, m] : motions) {
    if (m.kind != WallMotion::Kind::Pressure) continue;
    const Wall* w = nullptr;
    for (const auto& x : s.walls)
      if (x.name == name) w = &x;
    if (!w) continue;  // unknown walls are reported by the scenario loader
    std::size_t ahead = 0;
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
      Vec3 n;
      double d;
      w->distance(s.particles.position[i], n, d);
      if (d > -s.particles.radius[i]) ++ahead;
    }
    if (ahead == 0)
      throw SetupError("stage '" + stage + "': wall '" + name + "' is pressure-controlled but no particle lies on its inward side (" +
                       std::to_string(s.particles.size()) +
                       " particles, all behind it): the servo would drive it at its max_speed without ever meeting a "
                       "load. Put particles under the wall, move the wall, or give it a displacement motion "
                       "(\"velocity\" or \"table\") instead of \"pressure\"");
  }
}

}  // namespace sparkdem
