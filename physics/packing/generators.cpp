#include "physics/packing/generators.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/error.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/body/gravity.hpp"

namespace sparkdem::physics {

namespace {
constexpr double kPi = 3.14159265358979323846;

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
    throw ConfigError("/material", "material index " + std::to_string(m) + " is not defined (" +
                                       std::to_string(s.materials.size()) + " materials)");
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
  for (int d = 0; d < 3; ++d)
    n *= std::max(0.0, std::floor(p_.hi[d] / p_.spacing + 1e-9) - std::ceil(p_.lo[d] / p_.spacing - 1e-9) + 1.0);
  return n;
}
void LatticeGenerator::generate(State& s) {
  const double rho = material_density(s, p_.material);
  const double r = 0.5 * p_.diameter;
  std::array<std::int64_t, 3> a{}, b{};
  for (int d = 0; d < 3; ++d) {
    // Lattice indices must fit an int64 (a huge lo or hi would overflow the cast below).
    if (!(std::abs(p_.lo[d] / p_.spacing) < 9e15)) throw ConfigError("/lo", "lo / spacing is out of range (|lo / spacing| >= 9e15)");
    if (!(std::abs(p_.hi[d] / p_.spacing) < 9e15)) throw ConfigError("/hi", "hi / spacing is out of range (|hi / spacing| >= 9e15)");
    a[d] = static_cast<std::int64_t>(std::ceil(p_.lo[d] / p_.spacing - 1e-9));
    b[d] = static_cast<std::int64_t>(std::floor(p_.hi[d] / p_.spacing + 1e-9));
  }
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
  s.add("min_radius_factor", &Params::min_radius_factor).unit("1").range(0.3, 1.0)
      .doc("the die may contract further, down to this x container_radius, until the target density is reached");
  s.add("gravity", &Params::gravity).unit("m/s^2").positive().doc("packing gravity (scaled for micron powders; reported)");
  s.add("ke_per_mass_below", &Params::ke_per_mass_below).unit("J/kg").positive().doc("settled threshold");
  s.add("max_overlap", &Params::max_overlap).unit("1").positive().doc("largest overlap / smaller radius allowed");
  s.add("damping_rate", &Params::damping_rate).unit("1/s").nonnegative().doc("background drag (0 = off)");
  s.add("material", &Params::material).nonnegative().doc("material index");
  return s;
}
double DepositGenerator::estimated_particles() const {
  // Built first so that the loader validates the distribution even when `particles` is given.
  const SizeDistribution d = make_distribution(p_.size_distribution);
  if (p_.particles > 0) return static_cast<double>(p_.particles);
  // Expected particle volume from the number distribution, by quadrature of the quantile function.
  double v = 0.0;
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    const double dd = quantile_number(d, (k + 0.5) / n);
    v += kPi / 6.0 * dd * dd * dd / n;
  }
  return p_.target_density * kPi * p_.container_radius * p_.container_radius * p_.container_height / v;
}
void DepositGenerator::generate(State& s) {
  const double rho = material_density(s, p_.material);
  const SizeDistribution dist = make_distribution(p_.size_distribution);
  std::vector<double> d;
  if (p_.particles > 0) {
    for (std::int64_t k = 0; k < p_.particles; ++k) d.push_back(sample_diameter(dist, s.rng));
  } else {
    d = sample_until_volume(dist, p_.target_density * kPi * p_.container_radius * p_.container_radius * p_.container_height, s.rng);
  }
  const DistributionReport rep = compare(dist, d);
  sampling_ = {{"psd_ks_distance", rep.ks_distance},       {"psd_d10_requested", rep.requested_d[0]},
               {"psd_d50_requested", rep.requested_d[1]}, {"psd_d90_requested", rep.requested_d[2]},
               {"psd_d10_sampled", rep.sampled_d[0]},     {"psd_d50_sampled", rep.sampled_d[1]},
               {"psd_d90_sampled", rep.sampled_d[2]},     {"psd_mean_d_sampled", rep.mean_d_sampled},
               {"psd_mean_d_requested", rep.mean_d_requested}};
  double vsum = 0.0;
  std::vector<double> radii;
  for (double x : d) { radii.push_back(0.5 * x); vsum += kPi / 6.0 * x * x * x; }
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
  double dmin = 1e300, dmax = 0.0;
  for (double x : s.particles.radius) { dmin = std::min(dmin, 2 * x); dmax = std::max(dmax, 2 * x); }
  r["diameter_min"] = dmin;
  r["diameter_max"] = dmax;
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
  s.add("mean_radius", &Params::mean_radius).unit("m").nonnegative()
      .doc("mean radius kept as given (density = N 4/3 pi r^3 (1+spread^2)/V, target_density unused); 0 = Eq. (1)");
  s.add("spread", &Params::spread).unit("1").range(0.0, 0.9).doc("relative half-width of the radius distribution");
  s.add("target_density", &Params::target_density).unit("1").range(0.05, 0.7).doc("packing density to reach");
  s.add("initial_scale", &Params::initial_scale).unit("1").range(0.05, 1.0).doc("radius scale at insertion");
  s.add("growth_time", &Params::growth_time).unit("s").nonnegative().doc("growth duration; 0 = 2000 stage steps");
  s.add("damping_rate", &Params::damping_rate).unit("1/s").nonnegative().doc("background drag (0 = off)");
  s.add("ke_per_mass_below", &Params::ke_per_mass_below).unit("J/kg").positive().doc("settled threshold");
  s.add("max_overlap", &Params::max_overlap).unit("1").positive().doc("largest overlap / smaller radius allowed");
  s.add("material", &Params::material).nonnegative().doc("material index");
  return s;
}
double FillGenerator::container_volume() const {
  if (p_.shape == "cylinder") return kPi * p_.radius * p_.radius * p_.length;
  return (p_.hi - p_.lo).prod();
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
  if (p_.shape == "cylinder") region = CylinderRegion{Vec3::Zero(), Vec3::UnitZ(), p_.radius, p_.length};
  else region = BoxRegion{p_.lo, p_.hi};
  if (!insert_random(s, small, region, rho, static_cast<std::int32_t>(p_.material)))
    throw SetupError("fill: random insertion failed; lower initial_scale");
  // Masses of the full-size particles are restored by the growth module.
  if (p_.shape == "cylinder") {
    add_wall(s, cylinder("die", Vec3::Zero(), Vec3::UnitZ(), p_.radius));
    add_wall(s, plane("bottom", Vec3::Zero(), Vec3::UnitZ()));
    add_wall(s, plane("top", Vec3(0, 0, p_.length), -Vec3::UnitZ()));
  } else {
    add_box_walls(s, p_.lo, p_.hi);
  }
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
  auto r = packing_report(s);
  r["mean_radius_formula"] = formula_mean_radius();
  if (s.particles.fields.has("radius_growth/scale") && s.particles.size())
    r["growth_scale"] = s.particles.fields.data("radius_growth/scale")[0];  // 1 = fully grown
  double rs = 0.0;
  for (double x : s.particles.radius) rs += x;
  r["mean_radius"] = s.particles.size() ? rs / static_cast<double>(s.particles.size()) : 0.0;
  return r;
}

// ----------------------------------------------------------------------------- radius growth
ParamSpec<RadiusGrowth::Params> RadiusGrowth::spec() {
  ParamSpec<Params> s("radius_growth", "module", "linear growth of all radii from s0 to s1 times their final size");
  s.add("s0", &Params::s0).unit("1").positive().doc("initial scale");
  s.add("s1", &Params::s1).unit("1").positive().doc("final scale");
  s.add("duration", &Params::duration).unit("s").nonnegative().doc("growth time");
  s.add("halt_overlap", &Params::halt_overlap).unit("1").nonnegative().doc("pause growth while the largest overlap ratio exceeds this (0 = never)");
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
                      "overlapping start in a box");
  s.add_vec3("lo", &Params::lo).unit("m").doc("box lower corner");
  s.add_vec3("hi", &Params::hi).unit("m").doc("box upper corner");
  s.add("particles", &Params::particles).min(1).doc("number of particles");
  s.add("target_density", &Params::target_density).unit("1").range(0.05, 0.7).doc("solid fraction setting the mean radius");
  s.add("spread", &Params::spread).unit("1").range(0.0, 0.9).doc("radii uniform in r(1 +- spread)");
  s.add("stiffness", &Params::stiffness).unit("J").positive().doc("k of the potential w(q)");
  s.add("max_iterations", &Params::max_iterations).min(1).doc("FIRE iteration limit");
  s.add("force_tolerance", &Params::force_tolerance).unit("1").positive().doc("stop when max|F| < tol k / r_mean");
  s.add("max_step", &Params::max_step).unit("1").positive().doc("largest move per iteration / radius");
  s.add("density", &Params::density).unit("kg/m^3").positive().doc("particle density");
  s.add("material", &Params::material).nonnegative().doc("material index");
  return s;
}

namespace {
/// Contact potential of seed 003 and its derivative (pure kernel):
///   w(q) = k (q - 1) ln q for 0 < q < 1, else 0;   w'(q) = k (ln q + 1 - 1/q)
inline double relax_w(double k, double q) { return q < 1.0 ? k * (q - 1.0) * std::log(q) : 0.0; }
inline double relax_dw(double k, double q) { return q < 1.0 ? k * (std::log(q) + 1.0 - 1.0 / q) : 0.0; }
}  // namespace

void RelaxGenerator::generate(State& s) {
  auto& p = s.particles;
  const double vbox = (p_.hi - p_.lo).prod();
  const double n = static_cast<double>(p_.particles);
  // Mean radius such that sum of volumes = target_density * V, with radii uniform in r(1 +- a):
  //   <r^3> = r^3 (1 + a^2)  for r(1 + a u), u uniform in [-1, 1]
  const double rbar = std::cbrt(p_.target_density * vbox / (n * 4.0 / 3.0 * kPi * (1.0 + p_.spread * p_.spread)));
  const std::size_t first = p.size();
  std::vector<double> radii;
  for (std::int64_t k = 0; k < p_.particles; ++k) radii.push_back(rbar * (1.0 + p_.spread * (2.0 * uniform_open01(s.rng) - 1.0)));
  // Exact target: rescale so the solid volume is exactly target_density * V.
  double v = 0.0;
  for (double r : radii) v += 4.0 / 3.0 * kPi * r * r * r;
  const double fix = std::cbrt(p_.target_density * vbox / v);
  for (double& r : radii) r *= fix;
  for (double r : radii) {
    Vec3 x;
    for (int d = 0; d < 3; ++d) x[d] = p_.lo[d] + r + uniform_open01(s.rng) * (p_.hi[d] - p_.lo[d] - 2 * r);
    p.add(x, r, p_.density * 4.0 / 3.0 * kPi * r * r * r, static_cast<std::int32_t>(p_.material));
  }
  add_box_walls(s, p_.lo, p_.hi);

  // FIRE (Bitzek et al., PRL 97, 170201, 2006) on U, unit masses, positions in metres.
  const double k = p_.stiffness;
  const std::size_t N = p.size();
  std::vector<Vec3> v_(N, Vec3::Zero()), F(N);
  double dt = 0.1 * rbar, dt_max = 1.0 * rbar;  // scaled "time": displacement per unit force rbar/k
  double alpha = 0.1;
  int since_neg = 0;
  const double skin = 0.5 * rbar;
  VerletTracker tracker;
  std::vector<std::array<Index, 2>> pairs;
  std::int64_t it = 0;
  double fmax = 0.0, energy = 0.0;
  auto forces = [&]() {
    if (tracker.needs_rebuild(p.position, p.radius, skin)) {
      pairs = find_pairs(p.position, p.radius, skin);
      tracker.mark_built(p.position, p.radius);
    }
    for (auto& f : F) f.setZero();
    energy = 0.0;
    for (const auto& pr : pairs) {
      const Vec3 d = p.position[pr[1]] - p.position[pr[0]];
      const double dist = d.norm(), R = p.radius[pr[0]] + p.radius[pr[1]];
      const double q = std::max(dist / R, 1e-6);
      if (q >= 1.0) continue;
      energy += relax_w(k, q);
      const Vec3 dir = dist > 0.0 ? Vec3(d / dist) : Vec3(Vec3::UnitX());
      const Vec3 f = relax_dw(k, q) / R * dir;  // on i: w'(q)/R * (p_j - p_i)/|.| (w' < 0: repulsive)
      F[pr[0]] += f;
      F[pr[1]] -= f;
    }
    for (std::size_t i = first; i < N; ++i)
      for (const auto& w : s.walls) {
        Vec3 nrm;
        double dd;
        w.distance(p.position[i], nrm, dd);
        const double q = std::max(dd / p.radius[i], 1e-6);
        if (q >= 1.0) continue;
        energy += relax_w(k, q);
        F[i] -= relax_dw(k, q) / p.radius[i] * nrm;
      }
    fmax = 0.0;
    for (const auto& f : F) fmax = std::max(fmax, f.norm());
  };
  forces();
  const double ftol = p_.force_tolerance * k / rbar;
  for (it = 0; it < p_.max_iterations && fmax > ftol; ++it) {
    double P = 0.0, vn = 0.0, fn = 0.0;
    for (std::size_t i = 0; i < N; ++i) { P += F[i].dot(v_[i]); vn += v_[i].squaredNorm(); fn += F[i].squaredNorm(); }
    vn = std::sqrt(vn);
    fn = std::sqrt(fn);
    if (P > 0.0) {
      for (std::size_t i = 0; i < N; ++i) v_[i] = (1.0 - alpha) * v_[i] + alpha * vn / fn * F[i];
      if (++since_neg > 5) { dt = std::min(dt * 1.1, dt_max); alpha *= 0.99; }
    } else {
      for (auto& x : v_) x.setZero();
      dt *= 0.5;
      alpha = 0.1;
      since_neg = 0;
    }
    // Semi-implicit Euler with a displacement cap of max_step * r.
    for (std::size_t i = 0; i < N; ++i) {
      v_[i] += dt * F[i];
      Vec3 dx = dt * v_[i];
      const double cap = p_.max_step * p.radius[i];
      if (dx.norm() > cap) dx *= cap / dx.norm();
      p.position[i] += dx;
    }
    forces();
  }
  result_ = {{"fire_iterations", static_cast<double>(it)}, {"fire_max_force_relative", fmax * rbar / k},
             {"fire_energy", energy}, {"mean_radius", rbar * fix}};
  for (auto& vel : p.velocity) vel.setZero();
}
std::map<std::string, double> RelaxGenerator::report(const State& s) const {
  auto r = packing_report(s);
  r.insert(result_.begin(), result_.end());
  return r;
}

}  // namespace sparkdem::physics
