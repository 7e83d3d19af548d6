#include "physics/electrical/branch_models.hpp"

#include <cmath>
#include <limits>

#include "physics/electrical/conductance_kernels.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace el = electrical;

namespace {

el::HemisphereLaw hemisphere_law(const std::string& name) {
  if (name == "reading_b") return el::HemisphereLaw::reading_b();
  if (name == "reading_c") return el::HemisphereLaw::reading_c();
  if (name == "fe_table") return el::HemisphereLaw::fe_table();
  return el::HemisphereLaw::reading_a();
}
}  // namespace

double branch_model_near_gap(const BranchModel& m) {
  if (m.model == "tunnelling") return m.tunnel_cutoff;
  if (m.model == "touching" || m.model == "transmission_surface") return m.touch_tolerance;
  return 0.0;
}

void resolve_touch_tolerance(BranchModel& m, double touch_tolerance_relative, const State& s) {
  if (!(touch_tolerance_relative > 0.0) || s.particles.size() == 0) return;
  m.touch_tolerance = touch_tolerance_relative * s.particles.mean_radius();
}

namespace {
/// The necks before the grain-boundary-fraction correction (Eqs. 21 and CV, capped at r_min).
std::vector<double> uncorrected_neck_radii(const BranchModel& m, const State& s, const InteractionGraph& g) {
  const auto& p = s.particles;
  auto radius = [&](Index v) { return g.is_wall_node(v) ? kInf : p.radius[v]; };
  std::vector<double> a(g.size(), 0.0);
  for (std::size_t e = 0; e < g.size(); ++e) {
    const double ra = radius(g.a[e]), rb = radius(g.b[e]);
    const bool law_neck = m.neck == "law" && g.kind[e] == EdgeKind::Neck;
    if (law_neck)
      a[e] = g.radius[e];
    else if (g.overlap[e] > 0.0 && std::isfinite(ra) && std::isfinite(rb))
      a[e] = m.neck == "cv" ? el::cv_neck_radius(ra, rb, g.overlap[e]) : el::coble_neck_radius(ra, rb, g.overlap[e]);
    // A neck never exceeds the smaller particle (§7.9; the kernels leave the cap to the caller):
    // the Coble neck of a deep overlap would (1.8 r_min at h = 0.9 r_min, size ratio 10), and
    // without the grain-boundary-fraction correction nothing else caps it.
    a[e] = std::min(a[e], std::min(ra, rb));
  }
  return a;
}

std::vector<double> neck_graph_radii(const State& s, const InteractionGraph& g) {
  std::vector<double> node_r(g.nodes());
  for (std::size_t v = 0; v < g.nodes(); ++v) node_r[v] = g.is_wall_node(static_cast<Index>(v)) ? kInf : s.particles.radius[v];
  return node_r;
}

/// The network's necks from the uncorrected ones: Eqs. 22-25 when the model has the correction.
std::vector<double> corrected_if_enabled(const BranchModel& m, const InteractionGraph& g, std::vector<double> raw,
                                         const std::vector<double>& node_r) {
  return m.gbf_correction ? el::corrected_neck_radii(g.a, g.b, raw, node_r) : raw;
}
}  // namespace

std::vector<double> sintered_neck_radii(const BranchModel& m, const State& s, const InteractionGraph& g) {
  return corrected_if_enabled(m, g, uncorrected_neck_radii(m, s, g), neck_graph_radii(s, g));
}

NetworkNecks network_necks(const BranchModel& m, const State& s, const InteractionGraph& g) {
  const std::vector<double> raw = uncorrected_neck_radii(m, s, g);
  const std::vector<double> node_r = neck_graph_radii(s, g);
  const std::vector<double> a = corrected_if_enabled(m, g, raw, node_r);  // the necks the network conducts through
  const std::vector<double> alpha = el::grain_boundary_fraction_factors(g.a, g.b, raw, node_r);
  NetworkNecks out;
  std::vector<char> has_neck(g.nodes(), 0);
  for (std::size_t e = 0; e < g.size(); ++e) {
    if (!(a[e] > 0.0) || g.is_wall_node(g.a[e]) || g.is_wall_node(g.b[e])) continue;
    out.ratios.push_back(a[e] / std::min(node_r[g.a[e]], node_r[g.b[e]]));
    has_neck[g.a[e]] = has_neck[g.b[e]] = 1;
  }
  double with = 0.0, bound = 0.0;
  for (std::size_t v = 0; v < g.nodes(); ++v)
    if (has_neck[v]) {
      with += 1.0;
      if (alpha[v] < 1.0) bound += 1.0;
    }
  out.bound_share = with > 0.0 ? bound / with : kNaN;
  return out;
}

double hemisphere_access_conductance(const BranchModel& m, double kappa_S_per_m, double r_m, double a_m) {
  return el::hemisphere_conductance(hemisphere_law(m.hemisphere), kappa_S_per_m, r_m, a_m);
}

double layer_conductance(const BranchModel& m, double kappa_S_per_m, double a_m) {
  return m.gb_thickness > 0.0 ? el::grain_boundary_layer_conductance(kappa_S_per_m, a_m, m.gb_epsilon, m.gb_thickness) : kInf;
}

std::vector<double> branch_conductances(const BranchModel& m, const State& s, const InteractionGraph& g, const std::vector<double>& k_edge,
                                        std::vector<double>& share_a) {
  const auto& p = s.particles;
  auto radius = [&](Index v) { return g.is_wall_node(v) ? kInf : p.radius[v]; };
  std::vector<double> G(g.size(), 0.0);
  share_a.assign(g.size(), 0.5);  // equal halves unless the model says otherwise
  if (m.model == "holm") {
    for (std::size_t e = 0; e < g.size(); ++e) {
      double a = 0.0;
      if (g.kind[e] == EdgeKind::Neck || (g.kind[e] == EdgeKind::Bond && g.radius[e] > 0.0))
        a = g.radius[e];
      else if (g.overlap[e] > 0.0)
        a = m.contact_radius == "hertz" ? el::hertz_contact_radius(radius(g.a[e]), radius(g.b[e]), g.overlap[e]) : g.radius[e];
      G[e] = a > 0.0 ? el::holm_conductance(a, k_edge[e], k_edge[e]) : 0.0;
    }
  } else if (m.model == "sintered_neck") {
    const std::vector<double> a = sintered_neck_radii(m, s, g);
    const el::HemisphereLaw law = hemisphere_law(m.hemisphere);
    const el::GrainBoundaryLayer layer = m.gb_thickness > 0.0 ? el::GrainBoundaryLayer::layer(m.gb_epsilon, m.gb_thickness)
                                                              : el::GrainBoundaryLayer::none();
    for (std::size_t e = 0; e < g.size(); ++e) {
      if (!(a[e] > 0.0)) continue;
      const double ra = radius(g.a[e]), rb = radius(g.b[e]), k = k_edge[e];
      G[e] = el::sintered_neck_conductance(law, layer, k, k, ra, rb, a[e]);
      // Side a: its hemisphere and half the grain-boundary layer (Eq. 17).
      const double Ka = std::isfinite(ra) ? el::hemisphere_conductance(law, k, ra, a[e]) : kInf;
      const double Kc = layer_conductance(m, k, a[e]);
      if (G[e] > 0.0) share_a[e] = (1.0 / Ka + 0.5 / Kc) * G[e];
    }
  } else if (m.model == "transmission_surface") {
    std::vector<double> S;
    if (m.alpha_constant > 0.0) {
      S.resize(g.nodes());
      for (std::size_t v = 0; v < g.nodes(); ++v) S[v] = m.alpha_constant * p.radius[v] * p.radius[v];
    } else {
      S = m.eccentricity ? el::transmission_surfaces(el::TransmissionSurfaceModel::platonic(), *m.eccentricity, p.radius, g.a, g.b)
                         : el::transmission_surfaces(el::TransmissionSurfaceModel::platonic(), p.position, p.radius, g.a, g.b);
    }
    for (std::size_t e = 0; e < g.size(); ++e)
      if (g.overlap[e] >= -m.touch_tolerance || g.kind[e] == EdgeKind::Bond)
        G[e] = el::transmission_conductance(1.0 / k_edge[e], g.distance[e], S[g.a[e]], S[g.b[e]]);
  } else {  // touching, tunnelling: the whole resistance is at the contact
    share_a.assign(g.size(), kNaN);
    const std::vector<double>* u = m.displacement_field.empty() ? nullptr : &p.fields.data(m.displacement_field);
    for (std::size_t e = 0; e < g.size(); ++e) {
      double overlap = g.overlap[e];
      if (u && !g.is_wall_node(g.a[e]) && !g.is_wall_node(g.b[e])) {
        const Vec3 d = p.position[g.b[e]] - p.position[g.a[e]];
        const double dn = d.norm();
        const std::size_t ia = static_cast<std::size_t>(g.a[e]), ib = static_cast<std::size_t>(g.b[e]);
        const Vec3 du((*u)[3 * ib] - (*u)[3 * ia], (*u)[3 * ib + 1] - (*u)[3 * ia + 1], (*u)[3 * ib + 2] - (*u)[3 * ia + 2]);
        if (dn > 0.0) overlap -= d.dot(du) / dn;
      }
      if (overlap >= -m.touch_tolerance)
        G[e] = el::touching_conductance(overlap, m.touch_tolerance, m.unit_conductance);
      else if (m.model == "tunnelling")
        G[e] = el::tunnelling_conductance(-overlap, m.tunnel_g0, m.tunnel_length, m.tunnel_cutoff);
      else if (m.open_conductance > 0.0)
        G[e] = m.open_conductance;
    }
  }
  return G;
}

}  // namespace sparkdem::physics
