#include "physics/packing/generators.hpp"

#include <sstream>

#include <algorithm>
#include <cmath>
#include <tuple>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "engine/state/pair_rows.hpp"
#include "physics/body/gravity.hpp"
#include "physics/packing/microstructure.hpp"
#include "engine/core/parallel.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {

Wall plane(const std::string& name, const Vec3& point, const Vec3& normal) {
  Wall w;
  w.name = name;
  w.shape = PlaneShape{point, normal.normalized()};
  return w;
}
Wall cylinder(const std::string& name, const Vec3& base, const Vec3& axis, double radius) {
  Wall w;
  w.name = name;
  w.shape = CylinderShape{base, axis.normalized(), radius};
  return w;
}
void add_wall(State& s, Wall w) {
  if (s.find_wall(w.name)) throw SetupError("a wall named '" + w.name + "' already exists; the generator creates it");
  s.walls.push_back(std::move(w));
}
double material_density(const State& s, std::int64_t m) {
  if (m < 0 || m >= static_cast<std::int64_t>(s.materials.size()))
    throw ConfigError("/material",
                      "material index " + std::to_string(m) + " is not defined (" + std::to_string(s.materials.size()) + " materials)");
  return s.materials[m].density;
}
void add_box_walls(State& s, const Vec3& lo, const Vec3& hi) {
  add_wall(s, plane("xlo", lo, Vec3::UnitX()));
  add_wall(s, plane("xhi", hi, -Vec3::UnitX()));
  add_wall(s, plane("ylo", lo, Vec3::UnitY()));
  add_wall(s, plane("yhi", hi, -Vec3::UnitY()));
  add_wall(s, plane("bottom", lo, Vec3::UnitZ()));
  add_wall(s, plane("top", hi, -Vec3::UnitZ()));
}
/// Expected particle count for a size distribution: `particles` if > 0, else the solid volume
/// [m^3] over the expected particle volume of the number distribution (quadrature of the
/// quantile function). Builds the distribution, so an invalid one throws ConfigError.
double expected_count(const SizeDistributionParams& sp, std::int64_t particles, double solid_volume) {
  const SizeDistribution d = make_distribution(sp);
  if (particles > 0) return static_cast<double>(particles);
  double v = 0.0;
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    const double dd = quantile_number(d, (k + 0.5) / n);
    v += kPi / 6.0 * dd * dd * dd / n;
  }
  return solid_volume / v;
}
/// Diameters [m] drawn from a size distribution: `particles` draws, or (particles = 0) draws
/// until their solid volume reaches solid_volume [m^3] (sample_until_volume). `sampling`
/// receives the requested vs sampled statistics (psd_* report keys).
std::vector<double> sample_diameters(const SizeDistributionParams& sp, std::int64_t particles, double solid_volume, std::mt19937_64& rng,
                                     std::map<std::string, double>& sampling) {
  const SizeDistribution dist = make_distribution(sp);
  std::vector<double> d;
  if (particles > 0) {
    for (std::int64_t k = 0; k < particles; ++k) d.push_back(sample_diameter(dist, rng));
  } else {
    d = sample_until_volume(dist, solid_volume, rng);
  }
  const DistributionReport rep = compare(dist, d);
  sampling = {{"psd_ks_distance", rep.ks_distance},          {"psd_d10_requested", rep.requested_d[0]},
              {"psd_d50_requested", rep.requested_d[1]},     {"psd_d90_requested", rep.requested_d[2]},
              {"psd_d10_sampled", rep.sampled_d[0]},         {"psd_d50_sampled", rep.sampled_d[1]},
              {"psd_d90_sampled", rep.sampled_d[2]},         {"psd_mean_d_sampled", rep.mean_d_sampled},
              {"psd_mean_d_requested", rep.mean_d_requested}};
  return d;
}
/// Report keys diameter_min, diameter_max [m] of the particles.
void add_diameter_range(const State& s, std::map<std::string, double>& r) {
  double dmin = 1e300, dmax = 0.0;
  for (double x : s.particles.radius) {
    dmin = std::min(dmin, 2 * x);
    dmax = std::max(dmax, 2 * x);
  }
  r["diameter_min"] = dmin;
  r["diameter_max"] = dmax;
}
/// Closed container of fill and relax: cylinder "die" (axis z through the origin, given radius)
/// with planes "bottom" (z = 0) and "top" (z = length), or the six planes of the box [lo, hi].
void add_container_walls(State& s, bool cylindrical, double radius, double length, const Vec3& lo, const Vec3& hi) {
  if (cylindrical) {
    add_wall(s, cylinder("die", Vec3::Zero(), Vec3::UnitZ(), radius));
    add_wall(s, plane("bottom", Vec3::Zero(), Vec3::UnitZ()));
    add_wall(s, plane("top", Vec3(0, 0, length), -Vec3::UnitZ()));
  } else {
    add_box_walls(s, lo, hi);
  }
}
void add_common_until(StageConfig& cfg, double density, double ke, double overlap) {
  if (density > 0.0) cfg.until.push_back({"packing_density", true, density});
  cfg.until.push_back({"kinetic_energy_per_mass", false, ke});
  cfg.until.push_back({"max_overlap_ratio", false, overlap});
}
}  // namespace

// ------------------------------------------------------------------------------------ lattice
ParamSpec<LatticeGenerator::Params> LatticeGenerator::spec() {
  ParamSpec<Params> s("lattice", "generator", "simple-cubic lattice points k*a (integer k) inside [lo, hi], at rest");
  s.add_vec3("lo", &Params::lo).unit("m").doc("lower corner of the fill region");
  s.add_vec3("hi", &Params::hi).unit("m").doc("upper corner of the fill region");
  s.add("spacing", &Params::spacing).unit("m").positive().doc("lattice constant a");
  s.add("diameter", &Params::diameter).unit("m").positive().doc("particle diameter");
  s.add("material", &Params::material).nonnegative().doc("material index");
  return s;
}
double LatticeGenerator::estimated_particles() const {
  double n = 1.0;
  for (int d = 0; d < 3; ++d) n *= std::max(0.0, std::floor(p_.hi[d] / p_.spacing + 1e-9) - std::ceil(p_.lo[d] / p_.spacing - 1e-9) + 1.0);
  return n;
}
void LatticeGenerator::validate(const State& scene, std::vector<Diagnostic>& errors) const {
  const double n = estimated_particles();
  if (!(n <= 1e9)) {
    errors.push_back({"", "the lattice would create " + std::to_string(n) + " particles (more than 1e9); check spacing, lo and hi"});
    return;
  }
  if (n > kCheapParticles) {
    // Not generated just to check it: the walls' interiors (half-spaces, a cylinder's inside) are
    // convex, so the lattice lies inside every wall when its 8 corner points do.
    check_corners(scene, errors);
    return;
  }
  State scratch;
  scratch.materials = scene.materials;
  scratch.walls = scene.walls;
  try {
    LatticeGenerator(p_).generate(scratch);
  } catch (const ConfigError& e) {
    errors.insert(errors.end(), e.diagnostics().begin(), e.diagnostics().end());
    return;
  }
  // Every particle centre inside every wall.
  for (const auto& w : scratch.walls) {
    std::size_t outside = 0;
    Id first = -1;
    for (std::size_t i = 0; i < scratch.particles.size(); ++i) {
      Vec3 normal;
      double d;
      w.distance(scratch.particles.position[i], normal, d);
      if (d < 0.0) {
        if (!outside) first = scratch.particles.id[i];
        ++outside;
      }
    }
    if (outside)
      errors.push_back({"", std::to_string(outside) + " of " + std::to_string(scratch.particles.size()) + " particles (first id " +
                                std::to_string(first) + ") lie outside wall '" + w.name + "': the walls do not enclose the particles"});
  }
}
void LatticeGenerator::index_range(std::array<std::int64_t, 3>& a, std::array<std::int64_t, 3>& b) const {
  for (int d = 0; d < 3; ++d) {
    // Lattice indices must fit an int64 (a huge lo or hi would overflow the cast below).
    if (!(std::abs(p_.lo[d] / p_.spacing) < 9e15)) throw ConfigError("/lo", "lo / spacing is out of range (|lo / spacing| >= 9e15)");
    if (!(std::abs(p_.hi[d] / p_.spacing) < 9e15)) throw ConfigError("/hi", "hi / spacing is out of range (|hi / spacing| >= 9e15)");
    a[d] = static_cast<std::int64_t>(std::ceil(p_.lo[d] / p_.spacing - 1e-9));
    b[d] = static_cast<std::int64_t>(std::floor(p_.hi[d] / p_.spacing + 1e-9));
  }
}
void LatticeGenerator::check_corners(const State& scene, std::vector<Diagnostic>& errors) const {
  std::array<std::int64_t, 3> a{}, b{};
  try {
    index_range(a, b);
  } catch (const ConfigError& e) {
    errors.insert(errors.end(), e.diagnostics().begin(), e.diagnostics().end());
    return;
  }
  for (const auto& w : scene.walls)
    for (int c = 0; c < 8; ++c) {
      const Vec3 x((c & 1 ? b[0] : a[0]) * p_.spacing, (c & 2 ? b[1] : a[1]) * p_.spacing, (c & 4 ? b[2] : a[2]) * p_.spacing);
      Vec3 normal;
      double d;
      w.distance(x, normal, d);
      if (d < 0.0) {
        errors.push_back({"", "the lattice's corner point (" + std::to_string(x[0]) + ", " + std::to_string(x[1]) + ", " +
                                  std::to_string(x[2]) + ") lies outside wall '" + w.name + "': the walls do not enclose the particles"});
        break;
      }
    }
}
void LatticeGenerator::generate(State& s) {
  const double rho = material_density(s, p_.material);
  const double r = 0.5 * p_.diameter;
  std::array<std::int64_t, 3> a{}, b{};
  index_range(a, b);
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i)
        s.particles.add(Vec3(i * p_.spacing, j * p_.spacing, k * p_.spacing), r, rho * 4.0 / 3.0 * kPi * r * r * r,
                        static_cast<std::int32_t>(p_.material));
}
std::map<std::string, double> LatticeGenerator::report(const State& s) const {
  return {{"particles", static_cast<double>(s.particles.size())}};
}

// ------------------------------------------------------------------------------------ deposit
ParamSpec<DepositGenerator::Params> DepositGenerator::spec() {
  ParamSpec<Params> s("deposit", "generator",
                      "seed 000: loose random insertion in a wide cylinder, fall under gravity while the die contracts "
                      "to its final radius, until the target packing density is reached and the bed has settled");
  s.add_group("size_distribution", &Params::size_distribution, size_distribution_spec());
  s.add("container_radius", &Params::container_radius).unit("m").positive().doc("final die radius");
  s.add("container_height", &Params::container_height).unit("m").positive().doc("bed height that sets the powder amount");
  s.add("target_density", &Params::target_density).unit("1").range(0.05, 0.74).doc("tap density to reach");
  s.add("particles", &Params::particles).nonnegative().doc("particle count; 0 = fill target_density*pi R^2 H");
  s.add("initial_radius_factor", &Params::initial_radius_factor).unit("1").min(1.0).doc("die radius at insertion / final");
  s.add("insertion_density", &Params::insertion_density).unit("1").range(0.01, 0.35).doc("solid fraction of the loose insertion");
  s.add("settle_time", &Params::settle_time).unit("s").nonnegative().doc("fall and settling time before the die contracts");
  s.add("contraction_time", &Params::contraction_time).unit("s").positive().doc("time for the die to reach container_radius");
  s.add("min_radius_factor", &Params::min_radius_factor)
      .unit("1")
      .range(0.3, 1.0)
      .doc("the die may contract further, down to this x container_radius, until the target density is reached");
  s.add("gravity", &Params::gravity).unit("m/s^2").positive().doc("packing gravity (scaled for micron powders; reported)");
  s.add("ke_per_mass_below", &Params::ke_per_mass_below).unit("J/kg").positive().doc("settled threshold");
  s.add("max_overlap", &Params::max_overlap).unit("1").positive().doc("largest overlap / smaller radius allowed");
  s.add("damping_rate", &Params::damping_rate).unit("1/s").nonnegative().doc("background drag (0 = off)");
  s.add("material", &Params::material).nonnegative().doc("material index");
  return s;
}
double DepositGenerator::estimated_particles() const {
  // Builds the distribution, so that the loader validates it even when `particles` is given.
  try {
    return expected_count(p_.size_distribution, p_.particles,
                          p_.target_density * kPi * p_.container_radius * p_.container_radius * p_.container_height);
  } catch (const ConfigError& e) {  // paths relative to the distribution object
    std::vector<Diagnostic> d = e.diagnostics();
    for (auto& x : d)
      if (x.path.rfind("/", 0) == 0) x.path = "/size_distribution" + x.path;
    throw ConfigError(d);
  }
}
void DepositGenerator::generate(State& s) {
  const double rho = material_density(s, p_.material);
  const std::vector<double> d = sample_diameters(p_.size_distribution, p_.particles,
                                                 p_.target_density * kPi * p_.container_radius * p_.container_radius * p_.container_height,
                                                 s.rng, sampling_);
  double vsum = 0.0;
  std::vector<double> radii;
  for (double x : d) {
    radii.push_back(0.5 * x);
    vsum += kPi / 6.0 * x * x * x;
  }
  const double r0 = p_.initial_radius_factor * p_.container_radius;
  const double h0 = vsum / (p_.insertion_density * kPi * r0 * r0);
  if (!insert_random(s, radii, CylinderRegion{Vec3::Zero(), Vec3::UnitZ(), r0, h0}, rho, static_cast<std::int32_t>(p_.material)))
    throw SetupError("deposit: random insertion failed; lower insertion_density");
  add_wall(s, cylinder("die", Vec3::Zero(), Vec3::UnitZ(), r0));
  add_wall(s, plane("bottom", Vec3::Zero(), Vec3::UnitZ()));
}
void DepositGenerator::configure_stage(StageConfig& cfg) const {
  WallMotion m;
  // The powder first falls and settles for settle_time; then the die contracts at constant speed,
  // reaching its final radius after contraction_time, and further (to min_radius_factor x the
  // final radius) if the bed is still looser than the target; it halts for good as soon as the
  // packing density reaches the target.
  const double speed = (p_.initial_radius_factor - 1.0) * p_.container_radius / p_.contraction_time;
  const double travel = (p_.initial_radius_factor - p_.min_radius_factor) * p_.container_radius;
  m.kind = WallMotion::Kind::Table;
  m.table_time = {0.0, p_.settle_time, p_.settle_time + travel / speed};
  m.table_disp = {0.0, 0.0, travel};
  m.halt_quantity = "packing_density";
  m.halt_value = p_.target_density;
  cfg.motions["die"] = m;
  // Reached = within 0.01 of the target density (the die halts at the target itself; the bed may
  // relax slightly afterwards), settled, small overlaps.
  add_common_until(cfg, p_.target_density - 0.01, p_.ke_per_mass_below, p_.max_overlap);
}
std::vector<std::unique_ptr<Module>> DepositGenerator::modules() const {
  std::vector<std::unique_ptr<Module>> m;
  m.push_back(std::make_unique<Gravity>(Gravity::Params{Vec3(0, 0, -p_.gravity)}));
  if (p_.damping_rate > 0.0) m.push_back(std::make_unique<ViscousDamping>(ViscousDamping::Params{p_.damping_rate}));
  return m;
}
std::vector<std::unique_ptr<Monitor>> DepositGenerator::monitors() const {
  std::vector<std::unique_ptr<Monitor>> m;
  m.push_back(std::make_unique<PackingMonitor>());
  return m;
}
std::map<std::string, double> DepositGenerator::report(const State& s) const {
  auto r = packing_report(s);
  r.insert(sampling_.begin(), sampling_.end());
  r["packing_gravity"] = p_.gravity;
  add_diameter_range(s, r);
  return r;
}

// --------------------------------------------------------------------------------------- fill
ParamSpec<FillGenerator::Params> FillGenerator::spec() {
  ParamSpec<Params> s("fill", "generator",
                      "seed 001 (GranOO cooker): N radii uniform +-spread about r = (phi V/(4/3 pi N))^(1/3), random "
                      "insertion at reduced size, frictionless growth to the target density, settling");
  s.add("shape", &Params::shape).choices({"cylinder", "box"}).doc("container shape");
  s.add("radius", &Params::radius).unit("m").positive().doc("cylinder radius");
  s.add("length", &Params::length).unit("m").positive().doc("cylinder length along z from z = 0");
  s.add_vec3("lo", &Params::lo).unit("m").doc("box lower corner");
  s.add_vec3("hi", &Params::hi).unit("m").doc("box upper corner");
  s.add("particles", &Params::particles).min(1).doc("number of elements N_DE");
  s.add("mean_radius", &Params::mean_radius)
      .unit("m")
      .nonnegative()
      .doc("mean radius kept as given (density = N 4/3 pi r^3 (1+spread^2)/V, target_density unused); 0 = Eq. (1)");
  s.add("spread", &Params::spread).unit("1").range(0.0, 0.9).doc("relative half-width of the radius distribution");
  s.add("target_density", &Params::target_density).unit("1").range(0.05, 0.7).doc("packing density to reach");
  s.add("initial_scale", &Params::initial_scale).unit("1").range(0.05, 1.0).doc("radius scale at insertion");
  s.add("growth_time", &Params::growth_time).unit("s").nonnegative().doc("growth duration; 0 = 2000 stage steps");
  s.add("damping_rate", &Params::damping_rate).unit("1/s").nonnegative().doc("background drag (0 = off)");
  s.add("ke_per_mass_below", &Params::ke_per_mass_below).unit("J/kg").positive().doc("settled threshold");
  s.add("max_overlap", &Params::max_overlap).unit("1").positive().doc("largest overlap / smaller radius allowed");
  s.add("material", &Params::material).nonnegative().doc("material index");
  s.add("neighbour_gap_relative", &Params::neighbour_gap_relative)
      .unit("1")
      .doc(
          "report seed 001's microstructure with neighbours at gaps <= this * r_mean: neighbour and eccentricity "
          "histograms (Figs. 2, 4), eccentric shares, the wall density profile (< 0: off)");
  return s;
}
FillGenerator::FillGenerator(const Params& p) : p_(p) {
  // With a given mean radius, N radii uniform in r(1 +- spread) have <r^3> = r^3 (1 + spread^2),
  // so their solid fraction N 4/3 pi r^3 (1 + spread^2) / V must not exceed 0.74 (densest sphere
  // packing). (Without mean_radius, Eq. 1 sizes the radii to exactly target_density <= 0.7.)
  if (!(p_.mean_radius > 0.0)) return;
  const double volume = container_volume(), phi = expected_density();
  if (!(volume > 0.0) || !(phi <= 0.74)) {
    std::ostringstream msg;
    msg.precision(4);
    msg << p_.particles << " particles of mean radius " << p_.mean_radius << " m (spread " << p_.spread
        << ") do not fit the container of volume " << volume << " m^3: solid fraction " << phi
        << " > 0.74; use fewer particles, a smaller mean_radius or a larger container";
    throw ConfigError("/particles", msg.str());
  }
}
double FillGenerator::container_volume() const {
  return p_.shape == "cylinder" ? kPi * p_.radius * p_.radius * p_.length : (p_.hi - p_.lo).prod();
}
double FillGenerator::expected_density() const {
  if (p_.mean_radius <= 0.0) return p_.target_density;
  const double r = p_.mean_radius;
  return static_cast<double>(p_.particles) * 4.0 / 3.0 * kPi * r * r * r * (1.0 + p_.spread * p_.spread) / container_volume();
}
double FillGenerator::formula_mean_radius() const {
  return std::cbrt(p_.target_density * container_volume() / (4.0 / 3.0 * kPi * static_cast<double>(p_.particles)));
}
void FillGenerator::generate(State& s) {
  const double rho = material_density(s, p_.material);
  const double rbar = p_.mean_radius > 0.0 ? p_.mean_radius : formula_mean_radius();
  std::vector<double> radii;
  double vfinal = 0.0;
  for (std::int64_t k = 0; k < p_.particles; ++k) {
    const double r = rbar * (1.0 + p_.spread * (2.0 * uniform_open01(s.rng) - 1.0));
    radii.push_back(r);
    vfinal += 4.0 / 3.0 * kPi * r * r * r;
  }
  // Without mean_radius: the scale at which the particles fill exactly target_density of the
  // container (Eq. 1 up to the sampling of the radii). With mean_radius (GranOO's alternative
  // input) the radii are kept as given and the density is N 4/3 pi r^3 (1 + spread^2) / V.
  growth_scale_ = p_.mean_radius > 0.0 ? 1.0 : std::cbrt(p_.target_density * container_volume() / vfinal);
  std::vector<double> small(radii.size());
  for (std::size_t k = 0; k < radii.size(); ++k) small[k] = radii[k] * p_.initial_scale * growth_scale_;
  Region region;
  if (p_.shape == "cylinder")
    region = CylinderRegion{Vec3::Zero(), Vec3::UnitZ(), p_.radius, p_.length};
  else
    region = BoxRegion{p_.lo, p_.hi};
  if (!insert_random(s, small, region, rho, static_cast<std::int32_t>(p_.material)))
    throw SetupError("fill: random insertion failed; lower initial_scale");
  // Masses of the full-size particles are restored by the growth module.
  add_container_walls(s, p_.shape == "cylinder", p_.radius, p_.length, p_.lo, p_.hi);
}
void FillGenerator::configure_stage(StageConfig& cfg) const {
  // Reached = grown (or jammed), settled, small overlaps, and within 0.01 of the target density.
  add_common_until(cfg, expected_density() - 0.01, p_.ke_per_mass_below, p_.max_overlap);
  cfg.until.push_back({"growth_complete", true, 1.0});
}
std::vector<std::unique_ptr<Module>> FillGenerator::modules() const {
  std::vector<std::unique_ptr<Module>> m;
  RadiusGrowth::Params g;
  g.s0 = p_.initial_scale;
  g.s1 = 1.0;
  g.duration = p_.growth_time;
  g.halt_overlap = 0.5 * p_.max_overlap;
  m.push_back(std::make_unique<RadiusGrowth>(g));
  if (p_.damping_rate > 0.0) m.push_back(std::make_unique<ViscousDamping>(ViscousDamping::Params{p_.damping_rate}));
  return m;
}
namespace {
class GrowthMonitor final : public Monitor {
 public:
  std::vector<std::string> columns(const State&) const override { return {"growth_complete"}; }
  std::vector<double> values(const State& s) const override {
    return {s.particles.fields.has("radius_growth/scale") && !s.particles.fields.data("radius_growth/scale").empty() &&
                    s.particles.fields.data("radius_growth/scale")[0] >= 1.0
                ? 1.0
                : 0.0};
  }
};
}  // namespace
std::vector<std::unique_ptr<Monitor>> FillGenerator::monitors() const {
  std::vector<std::unique_ptr<Monitor>> m;
  m.push_back(std::make_unique<PackingMonitor>());
  m.push_back(std::make_unique<GrowthMonitor>());
  return m;
}
std::map<std::string, double> FillGenerator::report(const State& s) const {
  auto r = packing_report(s, p_.neighbour_gap_relative);
  r["mean_radius_formula"] = formula_mean_radius();
  if (s.particles.fields.has("radius_growth/scale") && s.particles.size())
    r["growth_scale"] = s.particles.fields.data("radius_growth/scale")[0];  // 1 = fully grown
  r["mean_radius"] = s.particles.mean_radius();
  return r;
}

// ----------------------------------------------------------------------------- radius growth
ParamSpec<RadiusGrowth::Params> RadiusGrowth::spec() {
  ParamSpec<Params> s("radius_growth", "module", "linear growth of all radii from s0 to s1 times their final size");
  s.add("s0", &Params::s0).unit("1").positive().doc("initial scale");
  s.add("s1", &Params::s1).unit("1").positive().doc("final scale");
  s.add("duration", &Params::duration).unit("s").nonnegative().doc("growth time");
  s.add("halt_overlap", &Params::halt_overlap)
      .unit("1")
      .nonnegative()
      .doc("pause growth while the largest overlap ratio exceeds this (0 = never)");
  return s;
}
void RadiusGrowth::declare(Declarations& d) const {
  d.particle_fields.push_back({"radius_growth/radius_final", 1, "m", 0.0, false});
  d.particle_fields.push_back({"radius_growth/mass_final", 1, "kg", 0.0, false});
  d.particle_fields.push_back({"radius_growth/scale", 1, "1", 0.0, false});
  d.writes = {"radius", "mass", "inertia"};
}
void RadiusGrowth::bind(State& s) {
  auto& p = s.particles;
  auto& rf = p.fields.data("radius_growth/radius_final");
  auto& mf = p.fields.data("radius_growth/mass_final");
  auto& sc = p.fields.data("radius_growth/scale");
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (rf[i] > 0.0) continue;  // restored from a checkpoint
    rf[i] = p.radius[i] / p_.s0;
    mf[i] = p.mass[i] / (p_.s0 * p_.s0 * p_.s0);
    sc[i] = p_.s0;
  }
}
void RadiusGrowth::advance(State& s, const StepInfo& step) {
  auto& p = s.particles;
  if (p.size() == 0) return;
  const auto& rf = p.fields.data("radius_growth/radius_final");
  const auto& mf = p.fields.data("radius_growth/mass_final");
  auto& sc = p.fields.data("radius_growth/scale");
  if (sc[0] >= p_.s1) return;  // fully grown: radii stay as they are
  // Grow by ds per step while the largest overlap of the last contact pass stays below
  // halt_overlap; pause otherwise (a jammed packing pauses for good and never reaches s1).
  const double T = p_.duration > 0.0 ? p_.duration : 2000.0 * step.dt;
  const double ds = (p_.s1 - p_.s0) * step.dt / T;
  double worst = 0.0;
  if (p_.halt_overlap > 0.0) {
    const auto& ov = s.contacts.overlap();
    for (std::size_t r = 0; r < s.contacts.size(); ++r)
      if (ov[r] > 0.0) worst = std::max(worst, ov[r] / std::min(p.radius[s.contacts.i(r)], p.radius[s.contacts.j(r)]));
  }
  if (p_.halt_overlap > 0.0 && worst > p_.halt_overlap) return;
  const double scale = std::min(p_.s1, sc[0] + ds);
  for (std::size_t i = 0; i < p.size(); ++i) {
    p.radius[i] = rf[i] * scale;
    p.mass[i] = mf[i] * scale * scale * scale;
    p.inertia[i] = 0.4 * p.mass[i] * p.radius[i] * p.radius[i];
    sc[i] = scale;
  }
}

// -------------------------------------------------------------------------------------- relax
ParamSpec<RelaxGenerator::Params> RelaxGenerator::spec() {
  ParamSpec<Params> s("relax", "generator",
                      "seed 003: minimise U = sum k (q-1) ln q over overlapping pairs and walls with FIRE from a random "
                      "overlapping start in a box or a cylinder");
  s.add("shape", &Params::shape).choices({"box", "cylinder"}).doc("container shape");
  s.add_vec3("lo", &Params::lo).unit("m").doc("box lower corner");
  s.add_vec3("hi", &Params::hi).unit("m").doc("box upper corner");
  s.add("radius", &Params::radius).unit("m").positive().doc("cylinder radius (axis z through the origin)");
  s.add("length", &Params::length).unit("m").positive().doc("cylinder length along z from z = 0");
  s.add_group("size_distribution", &Params::size_distribution, size_distribution_spec(true));
  s.add("particles", &Params::particles)
      .nonnegative()
      .doc("number of particles; with a size_distribution 0 = as many as fill target_density * container volume");
  s.add("target_density", &Params::target_density)
      .unit("1")
      .range(0.05, 0.7)
      .doc("solid fraction: sets the mean radius (uniform spread) or the amount of powder (size_distribution, particles = 0)");
  s.add("spread", &Params::spread).unit("1").range(0.0, 0.9).doc("radii uniform in r(1 +- spread) (no size_distribution)");
  s.add("stiffness", &Params::stiffness).unit("J").positive().doc("k of the potential w(q)");
  s.add("max_iterations", &Params::max_iterations).min(1).doc("FIRE iteration limit");
  s.add("force_tolerance", &Params::force_tolerance).unit("1").positive().doc("stop when max|F| < tol k / r_mean");
  s.add("max_step", &Params::max_step).unit("1").positive().doc("largest move per iteration / radius");
  s.add("max_overlap", &Params::max_overlap)
      .unit("1")
      .nonnegative()
      .doc("also stop once the largest overlap / smaller radius (pairs and walls) is at most this; 0 = off");
  s.add("density", &Params::density)
      .unit("kg/m^3")
      .positive()
      .doc("particle density for the masses of later stages (set it to the material's; `material` only labels the particles)");
  s.add("material", &Params::material).nonnegative().doc("material index");
  s.add("neighbour_gap_relative", &Params::neighbour_gap_relative)
      .unit("1")
      .doc(
          "report seed 001's microstructure with neighbours at gaps <= this * r_mean: neighbour and eccentricity "
          "histograms (Figs. 2, 4), eccentric shares, the wall density profile (< 0: off)");
  s.add("interior_target_density", &Params::interior_target_density)
      .unit("1")
      .range(0.0, 0.74)
      .doc(
          "solid fraction more than 4 mean diameters from every face to reach: after the relaxation the radii and masses are rescaled "
          "by (target / interior)^(1/3) and relaxed again until within interior_tolerance (0: off); the overall fraction follows");
  s.add("interior_tolerance", &Params::interior_tolerance).unit("1").range(1e-6, 0.05).doc("|interior fraction - target| to stop at");
  s.add("interior_rounds", &Params::interior_rounds).min(1).doc("most rescale-and-relax rounds (not reaching the target: an error)");
  return s;
}

double RelaxGenerator::container_volume() const {
  return p_.shape == "cylinder" ? kPi * p_.radius * p_.radius * p_.length : (p_.hi - p_.lo).prod();
}

double RelaxGenerator::estimated_particles() const {
  if (p_.size_distribution.type == "none") {
    if (p_.particles < 1) throw ConfigError("/particles", "relax without a size_distribution needs particles >= 1, found 0");
    return static_cast<double>(p_.particles);
  }
  try {
    return expected_count(p_.size_distribution, p_.particles, p_.target_density * container_volume());
  } catch (const ConfigError& e) {
    std::vector<Diagnostic> d = e.diagnostics();
    for (auto& x : d) x.path = "/size_distribution" + x.path;
    throw ConfigError(d);
  }
}

std::vector<double> RelaxGenerator::radii(State& s) {
  std::vector<double> radii;
  if (p_.size_distribution.type != "none") {
    // Drawn diameters kept as they are (the distribution is the point); the solid volume is
    // target_density * V to within half the last particle (sample_until_volume).
    for (double d : sample_diameters(p_.size_distribution, p_.particles, p_.target_density * container_volume(), s.rng, sampling_))
      radii.push_back(0.5 * d);
    double rs = 0.0;
    for (double r : radii) rs += r;
    scale_radius_ = rs / static_cast<double>(radii.size());
    result_["mean_radius"] = scale_radius_;
    return radii;
  }
  const double n = static_cast<double>(p_.particles);
  // Mean radius such that sum of volumes = target_density * V, with radii uniform in r(1 +- a):
  //   <r^3> = r^3 (1 + a^2)  for r(1 + a u), u uniform in [-1, 1]
  const double rbar = std::cbrt(p_.target_density * container_volume() / (n * 4.0 / 3.0 * kPi * (1.0 + p_.spread * p_.spread)));
  for (std::int64_t k = 0; k < p_.particles; ++k) radii.push_back(rbar * (1.0 + p_.spread * (2.0 * uniform_open01(s.rng) - 1.0)));
  // Exact target: rescale so the solid volume is exactly target_density * V.
  double v = 0.0;
  for (double r : radii) v += 4.0 / 3.0 * kPi * r * r * r;
  const double fix = std::cbrt(p_.target_density * container_volume() / v);
  for (double& r : radii) r *= fix;
  scale_radius_ = rbar;
  result_["mean_radius"] = rbar * fix;
  return radii;
}

namespace {
/// Contact potential of seed 003 and its derivative (pure kernel):
///   w(q) = k (q - 1) ln q for 0 < q < 1, else 0;   w'(q) = k (ln q + 1 - 1/q)
inline double relax_w(double k, double q) { return q < 1.0 ? k * (q - 1.0) * std::log(q) : 0.0; }
inline double relax_dw(double k, double q) { return q < 1.0 ? k * (std::log(q) + 1.0 - 1.0 / q) : 0.0; }

/// One term of U: its value w(q) [J] and the overlap / smaller radius [1] (0 without contact).
struct RelaxTerm {
  double w = 0.0;
  double overlap = 0.0;
};
/// Pair term of U (seed 003): q = |x_j - x_i| / (r_i + r_j) (clamped at 1e-6); force on i
///   f_i = w'(q) / (r_i + r_j) (x_j - x_i) / |x_j - x_i|   (w' < 0: repulsive; j gets -f_i),
/// overlap ratio (1 - q)(r_i + r_j) / min(r_i, r_j). f_i = 0 and a zero term for q >= 1.
inline RelaxTerm relax_pair(double k, const Vec3& xi, const Vec3& xj, double ri, double rj, Vec3& fi) {
  const Vec3 d = xj - xi;
  const double dist = d.norm(), R = ri + rj;
  const double q = std::max(dist / R, 1e-6);
  fi.setZero();
  if (q >= 1.0) return {};
  const Vec3 dir = dist > 0.0 ? Vec3(d / dist) : Vec3(Vec3::UnitX());
  fi = relax_dw(k, q) / R * dir;
  return {relax_w(k, q), (1.0 - q) * R / std::min(ri, rj)};
}
/// Wall term of U: q = (distance of the centre from the wall) / r_i; force -w'(q)/r_i n along the
/// wall normal n (pointing into the container); overlap ratio 1 - q. Zero for q >= 1.
inline RelaxTerm relax_wall(double k, const Wall& w, const Vec3& x, double r, Vec3& f) {
  Vec3 nrm;
  double dd;
  w.distance(x, nrm, dd);
  const double q = std::max(dd / r, 1e-6);
  f.setZero();
  if (q >= 1.0) return {};
  f = -relax_dw(k, q) / r * nrm;
  return {relax_w(k, q), 1.0 - q};
}
}  // namespace

void RelaxGenerator::generate(State& s) {
  const std::size_t first = s.particles.size();
  place(s, radii(s));
  relax(s, first);
  if (p_.interior_target_density > 0.0) reach_interior_target(s, first);
  for (auto& vel : s.particles.velocity) vel.setZero();
}

void RelaxGenerator::place(State& s, const std::vector<double>& rad) const {
  auto& p = s.particles;
  for (double r : rad) {
    Vec3 x;
    if (p_.shape == "cylinder") {
      // Centre uniform in the cylinder shrunk by r: within radius - r of the axis, z in [r, length - r].
      const double rho = (p_.radius - r) * std::sqrt(uniform_open01(s.rng));
      const double phi = 2.0 * kPi * uniform_open01(s.rng);
      x = Vec3(rho * std::cos(phi), rho * std::sin(phi), r + uniform_open01(s.rng) * (p_.length - 2.0 * r));
    } else {
      for (int d = 0; d < 3; ++d) x[d] = p_.lo[d] + r + uniform_open01(s.rng) * (p_.hi[d] - p_.lo[d] - 2 * r);
    }
    p.add(x, r, p_.density * 4.0 / 3.0 * kPi * r * r * r, static_cast<std::int32_t>(p_.material));
  }
  add_container_walls(s, p_.shape == "cylinder", p_.radius, p_.length, p_.lo, p_.hi);
}

void RelaxGenerator::reach_interior_target(State& s, std::size_t first) {
  auto& p = s.particles;
  auto interior = [&] {
    const double d = 2.0 * p.mean_radius();
    return wall_density_profile(p.position, p.radius, container_region(s), 0.5 * d, 4.0 * d, 4.0 * d).interior;
  };
  double phi = interior();
  std::int64_t rounds = 0;
  for (; std::abs(phi - p_.interior_target_density) > p_.interior_tolerance; ++rounds) {
    if (!std::isfinite(phi))
      throw SetupError("relax: interior_target_density needs a container wider than 8 mean diameters (no interior 4 mean diameters in)");
    if (rounds == p_.interior_rounds)
      throw SetupError("relax: the interior solid fraction is " + std::to_string(phi) + " after " + std::to_string(rounds) +
                       " rescale-and-relax rounds, not within " + std::to_string(p_.interior_tolerance) + " of interior_target_density " +
                       std::to_string(p_.interior_target_density) + " (raise interior_rounds)");
    const double c = std::cbrt(p_.interior_target_density / phi);
    for (std::size_t i = first; i < p.size(); ++i) {
      p.radius[i] *= c;
      p.mass[i] *= c * c * c;
      p.inertia[i] = 0.4 * p.mass[i] * p.radius[i] * p.radius[i];
    }
    scale_radius_ *= c;
    relax(s, first);
    phi = interior();
  }
  result_["interior_rounds"] = static_cast<double>(rounds);
  result_["interior_density_reached"] = phi;
}

namespace {
/// The forces of U on every particle (pairs and walls) for FIRE, with their own Verlet list.
/// Parallel and deterministic: per-pair forces into an array, summed per particle through the CSR
/// incidence in increasing pair order (the serial order: bit-identical for any thread count).
class RelaxForces {
 public:
  RelaxForces(State& s, std::size_t first, double k, double skin) : s_(s), first_(first), k_(k), skin_(skin) {}
  /// F[i] for every particle; returns {max |F|, max overlap ratio}.
  std::pair<double, double> evaluate(std::vector<Vec3>& F) {
    auto& p = s_.particles;
    if (tracker_.needs_rebuild(p.position, p.radius, skin_)) rebuild();
    const std::int64_t np = static_cast<std::int64_t>(pairs_.size()), n = static_cast<std::int64_t>(p.size());
    const std::size_t nw = s_.walls.size();
    const auto max_into = [](double& out, double m) { out = std::max(out, m); };
    double om = par::reduce(
        np, par::kHeavy, 0.0,
        [&](double& m, std::int64_t r) {
          m = std::max(m, relax_pair(k_, p.position[pairs_[r][0]], p.position[pairs_[r][1]], p.radius[pairs_[r][0]],
                                     p.radius[pairs_[r][1]], fpair_[r])
                              .overlap);
        },
        max_into);
    using Peaks = std::array<double, 2>;  // {max |F|, max overlap ratio against a wall}
    const auto peak_into = [](Peaks& out, const Peaks& m) {
      out[0] = std::max(out[0], m[0]);
      out[1] = std::max(out[1], m[1]);
    };
    const Peaks peaks = par::reduce(n, par::kHeavy, Peaks{0.0, 0.0}, [&](Peaks& m, std::int64_t i) {
      Vec3 f = Vec3::Zero();
      for (std::int64_t c = inc_start_[i]; c < inc_start_[i + 1]; ++c) {
        if (inc_row_[c] >= 0)
          f += fpair_[inc_row_[c]];
        else
          f -= fpair_[~inc_row_[c]];
      }
      for (std::size_t w = 0; w < nw; ++w) {
        if (!near_wall_[i * nw + w]) continue;
        Vec3 fw;
        m[1] = std::max(m[1], relax_wall(k_, s_.walls[w], p.position[i], p.radius[i], fw).overlap);
        f += fw;
      }
      F[i] = f;
      m[0] = std::max(m[0], f.norm());
    }, peak_into);
    return {peaks[0], std::max(om, peaks[1])};
  }
  /// U at the current positions, serially in the order of the pair list, then particles x walls.
  double energy() const {
    const auto& p = s_.particles;
    double e = 0.0;
    for (const auto& pr : pairs_) {
      Vec3 f;
      e += relax_pair(k_, p.position[pr[0]], p.position[pr[1]], p.radius[pr[0]], p.radius[pr[1]], f).w;
    }
    for (std::size_t i = first_; i < p.size(); ++i)
      for (const auto& w : s_.walls) {
        Vec3 f;
        e += relax_wall(k_, w, p.position[i], p.radius[i], f).w;
      }
    return e;
  }

 private:
  void rebuild() {
    auto& p = s_.particles;
    const std::size_t N = p.size(), nw = s_.walls.size();
    pairs_ = find_pairs(p.position, p.radius, skin_);
    tracker_.mark_built(p.position, p.radius);
    build_incidence(
        N, pairs_.size(), [&](std::size_t r) { return pairs_[r][0]; }, [&](std::size_t r) { return pairs_[r][1]; }, inc_start_, inc_row_);
    fpair_.resize(pairs_.size());
    // Wall candidates: within r + skin of the wall at the build (valid until the next rebuild, as
    // the pairs); the others have q > 1 against that wall and feel no force from it.
    near_wall_.assign(N * nw, 0);
    const std::int64_t n = static_cast<std::int64_t>(N), first = static_cast<std::int64_t>(first_);
    par::for_each(n - first, par::kLight, [&](std::int64_t k) {
      const std::int64_t i = first + k;
      for (std::size_t w = 0; w < nw; ++w) {
        Vec3 nrm;
        double d;
        s_.walls[w].distance(p.position[i], nrm, d);
        near_wall_[i * nw + w] = d < p.radius[i] + skin_;
      }
    });
  }
  State& s_;
  std::size_t first_;
  double k_, skin_;
  VerletTracker tracker_;
  std::vector<std::array<Index, 2>> pairs_;
  std::vector<Vec3> fpair_;
  std::vector<std::int64_t> inc_start_, inc_row_;
  std::vector<char> near_wall_;  ///< [i * nw + w]: particle i is a candidate of wall w
};
}  // namespace

void RelaxGenerator::relax(State& s, std::size_t first) {
  // FIRE (Bitzek et al., PRL 97, 170201, 2006) on U, unit masses, positions in metres; the FIRE
  // scalars P, |v|, |F| are summed serially.
  auto& p = s.particles;
  const double rbar = scale_radius_, k = p_.stiffness;
  const std::size_t N = p.size();
  const std::int64_t n = static_cast<std::int64_t>(N);
  std::vector<Vec3> v_(N, Vec3::Zero()), F(N);
  double dt = 0.1 * rbar, dt_max = 1.0 * rbar;  // scaled "time": displacement per unit force rbar/k
  double alpha = 0.1;
  int since_neg = 0;
  RelaxForces forces(s, first, k, 0.5 * rbar);
  double fmax = 0.0, overlap_max = 0.0;  // not a structured binding: clang 14 cannot capture one in a lambda
  std::tie(fmax, overlap_max) = forces.evaluate(F);
  const double ftol = p_.force_tolerance * k / rbar;
  // Converged: forces below the tolerance, or (max_overlap > 0) overlaps small enough.
  auto converged = [&]() { return fmax <= ftol || (p_.max_overlap > 0.0 && overlap_max <= p_.max_overlap); };
  std::int64_t it = 0;
  for (; it < p_.max_iterations && !converged(); ++it) {
    double P = 0.0, vn = 0.0, fn = 0.0;
    for (std::size_t i = 0; i < N; ++i) {
      P += F[i].dot(v_[i]);
      vn += v_[i].squaredNorm();
      fn += F[i].squaredNorm();
    }
    vn = std::sqrt(vn);
    fn = std::sqrt(fn);
    const double mix = P > 0.0 ? alpha : 1.0, vf = P > 0.0 ? alpha * vn / fn : 0.0;
    if (P > 0.0) {
      if (++since_neg > 5) {
        dt = std::min(dt * 1.1, dt_max);
        alpha *= 0.99;
      }
    } else {
      dt *= 0.5;
      alpha = 0.1;
      since_neg = 0;
    }
    // FIRE mixing v = (1 - alpha) v + alpha |v| F/|F| (P > 0) or v = 0 (P <= 0), then
    // semi-implicit Euler with a displacement cap of max_step * r.
    par::for_each(n, par::kLight, [&](std::int64_t i) {
      if (mix < 1.0)
        v_[i] = (1.0 - mix) * v_[i] + vf * F[i];
      else
        v_[i].setZero();
      v_[i] += dt * F[i];
      Vec3 dx = dt * v_[i];
      const double cap = p_.max_step * p.radius[i];
      if (dx.norm() > cap) dx *= cap / dx.norm();
      p.position[i] += dx;
    });
    std::tie(fmax, overlap_max) = forces.evaluate(F);
  }
  result_["fire_iterations"] = static_cast<double>(it) + (result_.count("fire_iterations") ? result_["fire_iterations"] : 0.0);
  result_["fire_max_force_relative"] = fmax * rbar / k;
  result_["fire_energy"] = forces.energy();
}

std::map<std::string, double> RelaxGenerator::report(const State& s) const {
  auto r = packing_report(s, p_.neighbour_gap_relative);
  r.insert(result_.begin(), result_.end());
  if (!sampling_.empty()) {
    r.insert(sampling_.begin(), sampling_.end());
    add_diameter_range(s, r);
  }
  return r;
}

}  // namespace sparkdem::physics
