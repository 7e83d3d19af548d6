#include "physics/packing/packing_common.hpp"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <cmath>
#include <fstream>
#include <numeric>
#include <sstream>
#include <unordered_map>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/packing/microstructure.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {
}

ParamSpec<SizeDistributionParams> size_distribution_spec(bool optional) {
  using P = SizeDistributionParams;
  ParamSpec<P> s("size_distribution", "object", "particle size distribution (diameters)");
  std::vector<std::string> kinds = {"lognormal", "table", "uniform"};
  if (optional) kinds.insert(kinds.begin(), "none");
  auto type = s.add("type", &P::type).choices(kinds).doc(optional ? "kind of distribution; none = not used" : "kind of distribution");
  if (optional) type.defaults_to(std::string("none"));
  s.add("d50", &P::d50).unit("m").positive().doc("lognormal median diameter (number basis)");
  s.add("sigma", &P::sigma).unit("1").positive().doc("lognormal standard deviation of ln d");
  s.add("d_min", &P::d_min).unit("m").nonnegative().doc("lower truncation (lognormal) or lower bound (uniform)");
  s.add("d_max", &P::d_max).unit("m").positive().doc("upper truncation (lognormal) or upper bound (uniform)");
  s.add("diameters", &P::diameters).unit("m").doc("table: increasing diameters");
  s.add("cumulative_fraction", &P::cumulative_fraction).unit("1").doc("table: cumulative fractions, last = 1");
  s.add("basis", &P::basis).choices({"number", "volume"}).doc("table: what the fractions count");
  s.add("csv", &P::csv).doc("table from a CSV file with columns diameter_m,cumulative_fraction (header optional)");
  return s;
}

SizeDistribution make_distribution(const SizeDistributionParams& p) {
  if (p.type == "lognormal") return make_lognormal(p.d50, p.sigma, p.d_min, p.d_max);
  if (p.type == "uniform") return make_uniform(p.d_min, p.d_max);
  std::vector<double> d = p.diameters, f = p.cumulative_fraction;
  if (!p.csv.empty()) {
    // Only a regular file of sensible size (a device such as /dev/zero would be read for ever).
    std::error_code ec;
    if (!std::filesystem::is_regular_file(p.csv, ec))
      throw ConfigError("/csv", "cannot read the file '" + p.csv + "': not a regular file (or missing)");
    if (std::filesystem::file_size(p.csv, ec) > (std::uintmax_t{64} << 20))
      throw ConfigError("/csv", "the file '" + p.csv + "' is larger than 64 MiB");
    std::ifstream in(p.csv);
    if (!in) throw ConfigError("/csv", "cannot read the file '" + p.csv + "'");
    d.clear();
    f.clear();
    std::string line;
    int lineno = 0;
    while (std::getline(in, line)) {
      ++lineno;
      if (line.empty() || line[0] == '#') continue;
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream is(line);
      double a, b;
      if (!(is >> a >> b)) {
        if (lineno == 1) continue;  // header
        throw ConfigError("/csv", "line " + std::to_string(lineno) + " of '" + p.csv + "': expected two numbers, found '" + line + "'");
      }
      d.push_back(a);
      f.push_back(b);
    }
  }
  if (d.empty()) throw ConfigError("/diameters", "a table distribution needs diameters (or csv), found none");
  return make_table(d, f, p.basis == "volume" ? SizeBasis::volume : SizeBasis::number);
}

bool insert_random(State& s, const std::vector<double>& radii_in, const Region& region, double density, std::int32_t material,
                   std::size_t max_attempts) {
  std::vector<double> radii = radii_in;
  std::sort(radii.begin(), radii.end(), std::greater<>());
  if (radii.empty()) return true;
  const double rmax = radii.front();
  const double h = 2.0 * rmax;
  // Bounding box of the region.
  Vec3 lo, hi;
  if (const auto* b = std::get_if<BoxRegion>(&region)) {
    lo = b->lo;
    hi = b->hi;
  } else {
    const auto& c = std::get<CylinderRegion>(region);
    const Vec3 top = c.base + c.height * c.axis;
    lo = c.base.cwiseMin(top) - Vec3::Constant(c.radius);
    hi = c.base.cwiseMax(top) + Vec3::Constant(c.radius);
  }
  std::unordered_map<std::int64_t, std::vector<Index>> grid;
  auto cell_of = [&](const Vec3& x, int d) { return static_cast<std::int64_t>(std::floor((x[d] - lo[d]) / h)); };
  auto key = [](std::int64_t a, std::int64_t b, std::int64_t c) { return (a * 73856093) ^ (b * 19349663) ^ (c * 83492791); };
  auto& p = s.particles;
  const std::size_t first = p.size();
  for (std::size_t k = 0; k < first; ++k)
    grid[key(cell_of(p.position[k], 0), cell_of(p.position[k], 1), cell_of(p.position[k], 2))].push_back(static_cast<Index>(k));
  auto u01 = [&]() { return uniform_open01(s.rng); };
  for (double r : radii) {
    bool placed = false;
    for (std::size_t a = 0; a < max_attempts && !placed; ++a) {
      Vec3 x;
      if (const auto* b = std::get_if<BoxRegion>(&region)) {
        for (int d = 0; d < 3; ++d) x[d] = b->lo[d] + r + u01() * (b->hi[d] - b->lo[d] - 2 * r);
      } else {
        const auto& c = std::get<CylinderRegion>(region);
        const double rho = (c.radius - r) * std::sqrt(u01());
        const double phi = 2 * kPi * u01();
        const Vec3 e1 = c.axis.unitOrthogonal(), e2 = c.axis.cross(e1);
        x = c.base + (r + u01() * (c.height - 2 * r)) * c.axis + rho * (std::cos(phi) * e1 + std::sin(phi) * e2);
      }
      const std::int64_t cx = cell_of(x, 0), cy = cell_of(x, 1), cz = cell_of(x, 2);
      bool ok = true;
      for (std::int64_t dz = -1; dz <= 1 && ok; ++dz)
        for (std::int64_t dy = -1; dy <= 1 && ok; ++dy)
          for (std::int64_t dx = -1; dx <= 1 && ok; ++dx) {
            auto it = grid.find(key(cx + dx, cy + dy, cz + dz));
            if (it == grid.end()) continue;
            for (Index j : it->second) {
              const double c2 = r + p.radius[j];
              if ((p.position[j] - x).squaredNorm() < c2 * c2) {
                ok = false;
                break;
              }
            }
          }
      if (!ok) continue;
      const Index i = p.add(x, r, density * 4.0 / 3.0 * kPi * r * r * r, material);
      grid[key(cx, cy, cz)].push_back(i);
      placed = true;
    }
    if (!placed) return false;
  }
  return true;
}

double bed_height(const State& s, const Vec3& floor_point, const Vec3& axis) {
  const auto& p = s.particles;
  if (p.size() == 0) return 0.0;
  double dsum = 0.0;
  for (double r : p.radius) dsum += 2.0 * r;
  const double w = 2.0 * dsum / static_cast<double>(p.size());
  const Vec3 e1 = axis.unitOrthogonal(), e2 = axis.cross(e1);
  std::map<std::pair<std::int64_t, std::int64_t>, double> top;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3 rel = p.position[i] - floor_point;
    const auto k = std::make_pair(static_cast<std::int64_t>(std::floor(rel.dot(e1) / w)),
                                  static_cast<std::int64_t>(std::floor(rel.dot(e2) / w)));
    const double t = rel.dot(axis) + p.radius[i];
    auto it = top.find(k);
    if (it == top.end())
      top.emplace(k, t);
    else
      it->second = std::max(it->second, t);
  }
  double sum = 0.0;
  for (const auto& [k, t] : top) sum += t;
  return sum / static_cast<double>(top.size());
}

Region container_region(const State& s) {
  const Wall* cyl = nullptr;
  for (const auto& w : s.walls)
    if (!w.is_plane()) {
      cyl = &w;
      break;
    }
  if (cyl) {
    const auto& c = std::get<CylinderShape>(cyl->shape);
    double zlo = -std::numeric_limits<double>::infinity(), zhi = std::numeric_limits<double>::infinity();
    for (const auto& w : s.walls) {
      if (!w.is_plane()) continue;
      const auto& pl = std::get<PlaneShape>(w.shape);
      const double cosang = pl.normal.dot(c.axis);
      const double z = (pl.point + w.u * pl.normal - c.base).dot(c.axis);
      if (cosang > 0.999) zlo = std::max(zlo, z);
      if (cosang < -0.999) zhi = std::min(zhi, z);
    }
    if (!std::isfinite(zlo)) throw SetupError("container: the cylinder wall has no floor plane normal to its axis");
    const Vec3 base = c.base + zlo * c.axis;
    if (!std::isfinite(zhi)) zhi = zlo + bed_height(s, base, c.axis);
    return CylinderRegion{base, c.axis, cyl->cylinder_radius(), std::max(zhi - zlo, 1e-300)};
  }
  Vec3 lo = Vec3::Constant(-std::numeric_limits<double>::infinity());
  Vec3 hi = Vec3::Constant(std::numeric_limits<double>::infinity());
  for (const auto& w : s.walls) {
    const auto& pl = std::get<PlaneShape>(w.shape);
    const Vec3 pt = pl.point + w.u * pl.normal;
    for (int d = 0; d < 3; ++d) {
      if (pl.normal[d] > 0.999) lo[d] = std::max(lo[d], pt[d]);
      if (pl.normal[d] < -0.999) hi[d] = std::min(hi[d], pt[d]);
    }
  }
  for (int d = 0; d < 2; ++d)
    if (!std::isfinite(lo[d]) || !std::isfinite(hi[d]))
      throw SetupError("container: the walls do not bound the particles in x and y (need planes or a cylinder)");
  if (!std::isfinite(lo[2])) throw SetupError("container: no floor plane (normal +z)");
  if (!std::isfinite(hi[2])) hi[2] = lo[2] + bed_height(s, Vec3(0, 0, lo[2]), Vec3::UnitZ());
  return BoxRegion{lo, hi};
}

namespace {
double max_diameter(const State& s) {
  double d = 0.0;
  for (double r : s.particles.radius) d = std::max(d, 2.0 * r);
  return d;
}
double wall_overlap_ratio(const State& s) {
  double ovr = 0.0;
  const auto& p = s.particles;
  for (const auto& w : s.walls)
    for (std::size_t i = 0; i < p.size(); ++i) {
      Vec3 n;
      double d;
      w.distance(p.position[i], n, d);
      if (d < p.radius[i]) ovr = std::max(ovr, (p.radius[i] - d) / p.radius[i]);
    }
  return ovr;
}
std::vector<std::array<Index, 2>> current_pairs(const State& s) {
  std::vector<std::array<Index, 2>> pairs(s.contacts.size());
  for (std::size_t r = 0; r < s.contacts.size(); ++r) pairs[r] = {s.contacts.i(r), s.contacts.j(r)};
  if (pairs.empty() && s.particles.size() > 1) pairs = find_pairs(s.particles.position, s.particles.radius, 0.0);
  return pairs;
}
}  // namespace

namespace {
/// The wall profile of seed-001 packings: bins of half a mean diameter, the cylinder's end
/// faces excluded over 4 mean diameters, the interior from 4 mean diameters.
DensityProfile profile(const State& s) {
  const double d = 2.0 * s.particles.mean_radius();
  return wall_density_profile(s.particles.position, s.particles.radius, container_region(s), 0.5 * d, 4.0 * d, 4.0 * d);
}
void add_microstructure(const State& s, double gap_relative, std::map<std::string, double>& r) {
  const NeighbourStats n = neighbour_stats(s.particles.position, s.particles.radius, gap_relative, container_region(s));
  r["neighbour_gap_relative"] = gap_relative;
  r["neighbours_mean"] = n.mean;
  r["eccentric_share"] = n.eccentric_share;
  r["eccentric_share_interior"] = n.eccentric_share_interior;
  r["interior_share"] = n.interior_share;
  r["neighbours_mean_core"] = n.mean_core;
  const DensityProfile p = profile(s);
  r["density_profile_bin_width"] = p.bin_width;
  r["density_profile_interior"] = p.interior;
  r["density_profile_max_deviation_beyond_4d"] = p.max_deviation_beyond;
}
}  // namespace

std::map<std::string, double> packing_report(const State& s, double neighbour_gap_relative) {
  const auto& p = s.particles;
  std::map<std::string, double> r;
  r["particles"] = static_cast<double>(p.size());
  if (p.size() == 0) return r;
  const Region region = container_region(s);
  r["packing_density"] = packing_density(p.position, p.radius, region);
  r["container_volume"] = region_volume(region);
  if (const auto* c = std::get_if<CylinderRegion>(&region)) {
    r["container_radius"] = c->radius;
    r["container_height"] = c->height;
  }
  const auto pairs = current_pairs(s);
  const double margin = max_diameter(s);
  try {
    const Region inner = shrink(region, margin);
    r["packing_density_interior"] = packing_density(p.position, p.radius, inner);
    r["interior_margin"] = margin;
    const auto ci = coordination_in_region(p.position, p.radius, pairs, 1e-9, inner);
    r["coordination_interior"] = ci.mean;
  } catch (const ConfigError&) { r["packing_density_interior"] = std::nan(""); }
  const auto c = coordination(p.position, p.radius, pairs, 1e-9);
  r["coordination_mean"] = c.mean;
  r["rattlers"] = static_cast<double>(c.rattlers);
  const auto o = overlap_stats(p.position, p.radius, pairs);
  r["max_overlap_ratio_pairs"] = o.max_relative;
  r["max_overlap_ratio_walls"] = wall_overlap_ratio(s);
  r["max_overlap_ratio"] = std::max(o.max_relative, r["max_overlap_ratio_walls"]);
  double vsum = 0.0;
  for (double rad : p.radius) vsum += 4.0 / 3.0 * kPi * rad * rad * rad;
  r["solid_volume"] = vsum;
  if (neighbour_gap_relative >= 0.0) add_microstructure(s, neighbour_gap_relative, r);
  return r;
}

std::map<std::string, std::vector<double>> packing_arrays(const State& s, double neighbour_gap_relative) {
  if (neighbour_gap_relative < 0.0 || s.particles.size() == 0) return {};
  const NeighbourStats n = neighbour_stats(s.particles.position, s.particles.radius, neighbour_gap_relative, container_region(s));
  return {
      {"neighbour_histogram", n.histogram}, {"eccentricity_histogram", n.eccentricity_histogram}, {"density_profile", profile(s).density}};
}

std::vector<int> packing_histogram(const State& s) {
  return coordination(s.particles.position, s.particles.radius, current_pairs(s), 1e-9).histogram;
}

std::vector<std::string> PackingMonitor::columns(const State&) const {
  return {"packing_density", "packing_density_interior", "coordination_interior"};
}

std::vector<double> PackingMonitor::values(const State& s) const {
  if (s.particles.size() == 0) return {0.0, 0.0, 0.0};
  const auto r = packing_report(s);
  return {r.at("packing_density"), r.at("packing_density_interior"), r.count("coordination_interior") ? r.at("coordination_interior") : 0.0};
}

}  // namespace sparkdem::physics
