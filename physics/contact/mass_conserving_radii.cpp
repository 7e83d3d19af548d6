#include "physics/contact/mass_conserving_radii.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/error.hpp"
#include "physics/thermal/expansion.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace kernel {

TruncatedVolume truncated_volume(double R, const CapNeighbour* nb, std::size_t n) {
  constexpr double pi = 3.14159265358979323846;
  TruncatedVolume t{4.0 / 3.0 * pi * R * R * R, 4.0 * pi * R * R};
  for (std::size_t k = 0; k < n; ++k) {
    const double h = R - radical_distance(nb[k].d, R, nb[k].r);
    if (!(h > 0.0)) continue;
    t.closed += h / (2.0 * R);
    const double hc = std::min(h, 2.0 * R);
    t.volume -= cap_volume(R, hc);
    // d cap / dR = pi h^2 + pi h (2R - h) dh/dR, dh/dR = 1 - R/d (a whole sphere past 2R: 4 pi R^2).
    t.dvolume -= h < 2.0 * R ? pi * hc * hc + pi * hc * (2.0 * R - hc) * (1.0 - R / nb[k].d) : 4.0 * pi * R * R;
  }
  return t;
}

double conserving_radius(double v0, double r_start, double r_lo, double r_hi, const CapNeighbour* nb, std::size_t n,
                         double rel_tol, bool& capped) {
  capped = false;
  if (truncated_volume(r_hi, nb, n).volume < v0) {
    capped = true;
    return r_hi;
  }
  double lo = r_lo, hi = r_hi, R = std::clamp(r_start, r_lo, r_hi);
  for (int it = 0; it < 60; ++it) {
    const TruncatedVolume t = truncated_volume(R, nb, n);
    const double f = t.volume - v0;
    if (std::abs(f) <= rel_tol * v0) return R;
    (f < 0.0 ? lo : hi) = R;
    double next = t.dvolume > 0.0 ? R - f / t.dvolume : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    R = next;
  }
  return R;
}

}  // namespace kernel

ParamSpec<MassConservingRadii::Params> MassConservingRadii::spec() {
  ParamSpec<Params> s("mass_conserving_radii", "module",
                      "Arzt radius growth: each particle with sintered necks grows so that its sphere less the caps on its necks' "
                      "radical planes keeps its volume; the growth of a pair goes to its viscous approach (needs the sintering law)");
  s.add("max_sweeps", &Params::max_sweeps).unit("1").range(1.0, 1e6).doc("most Jacobi sweeps per call (more: a physics error)");
  s.add("sweep_tolerance", &Params::sweep_tolerance)
      .unit("1")
      .range(1e-15, 1e-3)
      .doc("the sweeps stop when no radius changed by more than this x its free radius");
  s.add("max_growth", &Params::max_growth).unit("1").range(1.0, 10.0).doc("largest grown / free radius (an enclosed particle stops there)");
  s.add("dense_closed_surface", &Params::dense_closed_surface)
      .unit("1")
      .range(0.0, 1.0)
      .doc("closed surface share sum h / (2R) at which a particle is dense: incompressible, its pairs stop flowing (1: all closed)");
  s.add("tolerance", &Params::tolerance).unit("1").range(1e-15, 1e-3).doc("relative volume error at which a particle's Newton stops");
  return s;
}

void MassConservingRadii::declare(Declarations& d) const {
  d.particle_fields.push_back({thermal::kRadiusFactorField, 1, "1", 1.0, true});
  d.particle_fields.push_back({thermal::kClosedSurfaceField, 1, "1", 0.0, true});
  d.particle_fields.push_back({thermal::kDenseField, 1, "1", 0.0, true});
  d.reads.push_back("mass");
  d.reads.push_back("radius");
  d.writes.insert(d.writes.end(), {"radius", "inertia", thermal::kRadiusFactorField, thermal::kClosedSurfaceField, thermal::kDenseField});
}

namespace {


/// The contact-law columns the growth touches (SetupError when the law has none).
struct SinteringColumns {
  int neck, viscous, radius_sum;
};
SinteringColumns sintering_columns(const ContactTable& t) {
  const SinteringColumns c{t.column("neck_radius"), t.column("viscous_approach"), t.column("radius_sum")};
  if (c.neck < 0 || c.viscous < 0 || c.radius_sum < 0)
    throw SetupError(
        "mass_conserving_radii: the contact law has no neck_radius / viscous_approach / radius_sum state (use the sintering law)");
  return c;
}

}  // namespace

/// The sintered pairs (neck_radius > 0) of every particle, CSR: particle i's entries are
/// [start[i], start[i + 1]), each the other particle and the pair's centre distance [m].
struct NeckAdjacency {
  std::vector<std::size_t> start, other;
  std::vector<double> dist;
};

namespace {

/// Particle i's sintered neighbours as caps: centre distance and radius R[other] (coincident
/// centres, d = 0, left out).
void cap_neighbours(const NeckAdjacency& a, std::size_t i, const std::vector<double>& R, std::vector<kernel::CapNeighbour>& nb) {
  nb.clear();
  for (std::size_t e = a.start[i]; e < a.start[i + 1]; ++e)
    if (a.dist[e] > 0.0) nb.push_back({a.dist[e], R[a.other[e]]});
}

NeckAdjacency neck_adjacency(const ParticleStore& p, const ContactTable& t, int neck) {
  const std::size_t n = p.size();
  NeckAdjacency a;
  a.start.assign(n + 1, 0);
  std::vector<std::size_t> rows;
  for (std::size_t r = 0; r < t.size(); ++r)
    if (t.state(r)[neck] > 0.0) {
      rows.push_back(r);
      ++a.start[t.i(r) + 1];
      ++a.start[t.j(r) + 1];
    }
  for (std::size_t i = 0; i < n; ++i) a.start[i + 1] += a.start[i];
  std::vector<std::size_t> fill(a.start.begin(), a.start.end() - 1);
  a.other.resize(a.start[n]);
  a.dist.resize(a.start[n]);
  for (std::size_t r : rows) {
    const Index i = t.i(r), j = t.j(r);
    const double d = (p.position[i] - p.position[j]).norm();
    a.other[fill[i]] = j, a.dist[fill[i]++] = d;
    a.other[fill[j]] = i, a.dist[fill[j]++] = d;
  }
  return a;
}

}  // namespace

std::vector<double> MassConservingRadii::solve_radii(const NeckAdjacency& a, const std::vector<double>& r_free, std::vector<double> R,
                                                     const std::vector<double>& dense, Step step, Growth& out) const {
  const std::size_t n = r_free.size();
  std::vector<double> next(n);
  std::vector<kernel::CapNeighbour> nb;
  for (double change = 1.0; change > p_.sweep_tolerance;) {
    if (out.sweeps == p_.max_sweeps)
      throw PhysicsError(step, {}, "radius",
                         "mass_conserving_radii: the radii still change by " + std::to_string(change) + " x the free radius after " +
                             std::to_string(p_.max_sweeps) + " sweeps (raise max_sweeps or sweep_tolerance)");
    ++out.sweeps;
    out.capped = 0;
    change = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      next[i] = R[i];
      if (dense[i] > 0.5) continue;  // held: a closed particle's volume no radius sets
      cap_neighbours(a, i, R, nb);
      const double v0 = 4.0 / 3.0 * kPi * r_free[i] * r_free[i] * r_free[i];
      bool at_cap = false;
      next[i] = kernel::conserving_radius(v0, R[i], r_free[i], p_.max_growth * r_free[i], nb.data(), nb.size(), p_.tolerance, at_cap);
      out.capped += at_cap ? 1 : 0;
      change = std::max(change, std::abs(next[i] - R[i]) / r_free[i]);
    }
    R.swap(next);
  }
  return R;
}

MassConservingRadii::Growth MassConservingRadii::grow(State& s) const {
  auto& p = s.particles;
  auto& t = s.contacts;
  const SinteringColumns col = sintering_columns(t);
  const std::size_t n = p.size();
  auto& g = p.fields.data(thermal::kRadiusFactorField);
  const std::vector<double> r_old(p.radius.begin(), p.radius.end());
  std::vector<double> r_free(n);
  for (std::size_t i = 0; i < n; ++i) r_free[i] = p.radius[i] / (g[i] > 0.0 ? g[i] : 1.0);
  const NeckAdjacency adj = neck_adjacency(p, t, col.neck);
  Growth out;
  auto& dense = p.fields.data(thermal::kDenseField);
  const std::vector<double> R = solve_radii(adj, r_free, r_old, dense, s.step, out);
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(R[i]) || !(R[i] > 0.0))
      throw PhysicsError(s.step, {p.id[i]}, "radius", "mass-conserving growth gives radius " + std::to_string(R[i]) + " m");
    p.radius[i] = R[i];
    p.inertia[i] = 0.4 * p.mass[i] * R[i] * R[i];
    g[i] = R[i] / r_free[i];
  }
  // The growth of a pair is flow: u_s and the remembered radius sum take it (h - u_s unchanged).
  for (std::size_t r = 0; r < t.size(); ++r) {
    double* st = t.state(r);
    if (!(st[col.neck] > 0.0)) continue;
    const double grown = (R[t.i(r)] - r_old[t.i(r)]) + (R[t.j(r)] - r_old[t.j(r)]);
    st[col.viscous] += grown;
    if (st[col.radius_sum] > 0.0) st[col.radius_sum] += grown;
  }
  // Closed share of each surface: the caps' curved areas 2 pi R h over 4 pi R^2 (overlapping caps
  // counted twice, so it reaches 1 before the last pore closes), the dense flags, and the volume
  // the particles miss (dense ones held, capped ones at max_growth).
  auto& closed = p.fields.data(thermal::kClosedSurfaceField);
  std::vector<kernel::CapNeighbour> nb;
  double v_all = 0.0, v_missing = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    cap_neighbours(adj, i, R, nb);
    const kernel::TruncatedVolume tv = kernel::truncated_volume(R[i], nb.data(), nb.size());
    closed[i] = std::min(1.0, tv.closed);
    dense[i] = closed[i] >= p_.dense_closed_surface ? 1.0 : 0.0;
    out.dense += dense[i] > 0.5 ? 1 : 0;
    const double v0 = 4.0 / 3.0 * kPi * r_free[i] * r_free[i] * r_free[i];
    v_all += v0;
    v_missing += std::max(0.0, v0 - tv.volume);
  }
  out.missing_volume = v_all > 0.0 ? v_missing / v_all : 0.0;
  return out;
}

void MassConservingRadii::advance(State& s, const StepInfo&) { last_ = grow(s); }

std::vector<double> MassConservingRadii::column_values(const State& s) const {
  const auto& p = s.particles;
  if (p.size() == 0 || !p.fields.has(thermal::kRadiusFactorField)) return {1.0, 1.0, 0.0, 0.0, 0.0, 0.0};
  const auto& g = p.fields.data(thermal::kRadiusFactorField);
  double sum = 0.0, mx = 0.0;
  for (double x : g) sum += x, mx = std::max(mx, x);
  return {sum / static_cast<double>(g.size()), mx, static_cast<double>(last_.capped), static_cast<double>(last_.sweeps),
          static_cast<double>(last_.dense), last_.missing_volume};
}

}  // namespace sparkdem::physics
