#include "physics/packing/cpc_fillers.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "engine/core/error.hpp"
#include "engine/graph/laplacian.hpp"
#include "engine/neighbor/neighbor_search.hpp"
#include "physics/packing/size_distribution.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics {

namespace {
double max_radius(const std::vector<double>& r) {
  double m = 0.0;
  for (double x : r) m = std::max(m, x);
  return m;
}
double min_radius(const std::vector<double>& r) {
  double m = std::numeric_limits<double>::infinity();
  for (double x : r) m = std::min(m, x);
  return m;
}

/// Uniform grid over a fixed bounding box into which points are inserted one by one, with a
/// nearest-point query by growing shells of cells (for the aggregation's nearest cluster centre).
class ShellGrid {
 public:
  ShellGrid(const std::vector<Vec3>& x, double cell) : h_(cell) {
    lo_ = hi_ = x.empty() ? Vec3::Zero() : x[0];
    for (const auto& p : x) {
      lo_ = lo_.cwiseMin(p);
      hi_ = hi_.cwiseMax(p);
    }
    lo_ -= Vec3::Constant(2.0 * h_);  // room for points moved slightly outside (clamped otherwise)
    hi_ += Vec3::Constant(2.0 * h_);
    for (int d = 0; d < 3; ++d) n_[d] = static_cast<int>(std::floor((hi_[d] - lo_[d]) / h_)) + 1;
    cells_.resize(static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]);
  }
  void insert(Index i, const Vec3& p) { cells_[flat(cell_of(p))].push_back(i); }
  /// Calls f(i) for every inserted point whose cell meets the box [lo, hi] (a superset of the
  /// points inside it).
  template <class F>
  void for_each_in_box(const Vec3& lo, const Vec3& hi, F&& f) const {
    const std::array<int, 3> a = cell_of(lo), b = cell_of(hi);
    for (int z = a[2]; z <= b[2]; ++z)
      for (int y = a[1]; y <= b[1]; ++y)
        for (int x = a[0]; x <= b[0]; ++x)
          for (Index i : cells_[flat({x, y, z})]) f(i);
  }
  /// Nearest inserted point to p within distance < cutoff: its index, or -1; dist receives the distance.
  Index nearest(const std::vector<Vec3>& x, const Vec3& p, double cutoff, double& dist) const {
    const std::array<int, 3> c = cell_of(p);
    Index best = -1;
    double bd = std::numeric_limits<double>::infinity();
    const int kmax = std::max({n_[0], n_[1], n_[2]});
    for (int k = 0; k <= kmax; ++k) {
      // Every point of a cell k shells away is at least (k - 1) h from p.
      if ((k - 1) * h_ >= std::min(bd, cutoff)) break;
      for (int a = -k; a <= k; ++a)
        for (int b = -k; b <= k; ++b) {
          const bool face = std::abs(a) == k || std::abs(b) == k;
          for (int cz = -k; cz <= k; cz += face ? 1 : 2 * std::max(k, 1)) {
            const std::array<int, 3> q{c[0] + a, c[1] + b, c[2] + cz};
            if (q[0] < 0 || q[1] < 0 || q[2] < 0 || q[0] >= n_[0] || q[1] >= n_[1] || q[2] >= n_[2]) continue;
            for (Index i : cells_[flat(q)]) {
              const double d = (x[i] - p).norm();
              if (d < bd || (d == bd && i < best)) {
                bd = d;
                best = i;
              }
            }
          }
        }
    }
    dist = bd;
    return bd < cutoff ? best : -1;
  }

 private:
  std::array<int, 3> cell_of(const Vec3& p) const {
    std::array<int, 3> c{};
    for (int d = 0; d < 3; ++d) c[d] = std::clamp(static_cast<int>(std::floor((p[d] - lo_[d]) / h_)), 0, n_[d] - 1);
    return c;
  }
  std::size_t flat(const std::array<int, 3>& c) const { return (static_cast<std::size_t>(c[2]) * n_[1] + c[1]) * n_[0] + c[0]; }
  double h_;
  Vec3 lo_, hi_;
  std::array<int, 3> n_{};
  std::vector<std::vector<Index>> cells_;
};
}  // namespace

namespace cpc {

double max_relative_overlap(const std::vector<Vec3>& x, const std::vector<double>& r) {
  double m = 0.0;
  for (const auto& pr : find_pairs(x, r, 0.0)) {
    const double d = (x[pr[0]] - x[pr[1]]).norm();
    m = std::max(m, 1.0 - d / (r[pr[0]] + r[pr[1]]));
  }
  return m;
}

std::vector<std::array<Index, 2>> contact_pairs(const std::vector<Vec3>& x, const std::vector<double>& r, double tolerance) {
  std::vector<std::array<Index, 2>> out;
  if (x.empty()) return out;
  for (auto pr : find_pairs(x, r, 2.0 * tolerance * max_radius(r))) {
    const double sum = r[pr[0]] + r[pr[1]];
    if ((x[pr[0]] - x[pr[1]]).norm() - sum <= tolerance * sum) {
      if (pr[0] > pr[1]) std::swap(pr[0], pr[1]);
      out.push_back(pr);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<Index> cluster_labels(std::size_t n, const std::vector<std::array<Index, 2>>& pairs) {
  std::vector<Index> a, b;
  for (const auto& p : pairs) {
    a.push_back(p[0]);
    b.push_back(p[1]);
  }
  const std::vector<double> g(pairs.size(), 1.0);
  return component_roots(n, a, b, g);
}

OverlapRemoval remove_overlaps(std::vector<Vec3>& x, const std::vector<double>& r, double gamma, double tolerance,
                               std::int64_t max_iterations) {
  OverlapRemoval out;
  const std::size_t n = x.size();
  if (n == 0) {
    out.converged = true;
    return out;
  }
  // Verlet list with a skin of half the smallest radius: pairs that may overlap before the next
  // rebuild (the tracker rebuilds when some particle moved more than half the skin).
  const double skin = 0.5 * min_radius(r);
  VerletTracker tracker;
  std::vector<std::array<Index, 2>> pairs;
  std::vector<Vec3> grad(n);
  for (;;) {
    if (tracker.needs_rebuild(x, r, skin)) {
      pairs = find_pairs(x, r, skin);
      tracker.mark_built(x, r);
    }
    // Gradient dV/dr_i = sum_j g_ij (r_i - r_j) / r_ij over the overlapping pairs (unordered),
    // and the largest relative overlap of the current positions.
    std::fill(grad.begin(), grad.end(), Vec3::Zero());
    double worst = 0.0;
    for (const auto& pr : pairs) {
      const Index i = pr[0], j = pr[1];
      const Vec3 dx = x[i] - x[j];
      const double d = dx.norm(), sum = r[i] + r[j];
      const double g = d - sum;
      if (!(g < 0.0)) continue;
      worst = std::max(worst, -g / sum);
      // Coincident centres: separate along x (any fixed direction; a measure-zero event).
      const Vec3 u = d > 0.0 ? Vec3(dx / d) : Vec3(Vec3::UnitX());
      grad[i] += g * u;
      grad[j] -= g * u;
    }
    out.max_overlap = worst;
    if (worst <= tolerance) {
      out.converged = true;
      break;
    }
    if (out.iterations >= max_iterations) break;
    for (std::size_t i = 0; i < n; ++i) x[i] -= gamma * grad[i];
    ++out.iterations;
  }
  return out;
}

Aggregation aggregate(std::vector<Vec3>& x, const std::vector<double>& r, double lambda, double contact_tolerance, std::mt19937_64& rng) {
  Aggregation out;
  const std::size_t n = x.size();
  if (n == 0) return out;
  // Largest cluster of the contact graph (ties: the one with the smallest label, deterministic).
  const std::vector<Index> label = cluster_labels(n, contact_pairs(x, r, contact_tolerance));
  std::vector<std::size_t> size(n, 0);
  for (Index l : label) ++size[l];
  Index big = 0;
  for (std::size_t l = 0; l < n; ++l)
    if (size[l] > size[big]) big = static_cast<Index>(l);
  out.seed_cluster = size[big];
  const double rmax = max_radius(r);
  ShellGrid grid(x, 2.0 * rmax);
  std::vector<Index> rest;
  for (std::size_t i = 0; i < n; ++i) {
    if (label[i] == big)
      grid.insert(static_cast<Index>(i), x[i]);
    else
      rest.push_back(static_cast<Index>(i));
  }
  // Random order: Fisher-Yates with uniform_open01 (portable, unlike std::shuffle).
  for (std::size_t k = rest.size(); k > 1; --k) {
    const std::size_t m = std::min(k - 1, static_cast<std::size_t>(uniform_open01(rng) * static_cast<double>(k)));
    std::swap(rest[k - 1], rest[m]);
  }
  out.examined = rest.size();
  // Position reached by sliding j from `from` straight towards cluster centre i: the first
  // contact with ANY cluster sphere k, the smallest root s >= 0 of |from + s u - x_k| = R_k + R_j
  // (at the latest contact with i itself).
  auto slide = [&](Index j, const Vec3& from, Index i) {
    const double dist = (x[i] - from).norm();
    const Vec3 u = (x[i] - from) / dist;
    double s_stop = std::max(dist - (r[i] + r[j]), 0.0);
    const Vec3 end = from + s_stop * u;
    const Vec3 pad = Vec3::Constant(r[j] + rmax);
    grid.for_each_in_box(from.cwiseMin(end) - pad, from.cwiseMax(end) + pad, [&](Index k) {
      const Vec3 w = from - x[k];
      const double D = r[k] + r[j], b = w.dot(u), c = w.squaredNorm() - D * D;
      const double disc = b * b - c;
      if (disc < 0.0) return;
      const double s = -b - std::sqrt(disc);
      if (s >= 0.0 && s < s_stop) s_stop = s;
    });
    return Vec3(from + s_stop * u);
  };
  auto overlaps_cluster = [&](Index j, const Vec3& p) {
    bool hit = false;
    const Vec3 pad = Vec3::Constant(r[j] + rmax);
    grid.for_each_in_box(p - pad, p + pad, [&](Index k) { hit = hit || (p - x[k]).norm() < (r[k] + r[j]) * (1.0 - 1e-12); });
    return hit;
  };
  for (Index j : rest) {
    double d = 0.0;
    const Index i = grid.nearest(x, x[j], lambda * r[j], d);
    if (i >= 0) {
      const double touch = r[i] + r[j];
      if (d > touch) {
        // Slide towards the nearest cluster centre until the first contact: j then touches the
        // cluster without overlapping it (d_C = 2R exactly, the constraint of the paper's argmin).
        x[j] = slide(j, x[j], i);
      } else {
        // Already touching or overlapping the cluster (an earlier member landed on j): restart
        // the slide from outside, on the ray from x_i through x_j at 2, 4, 8, ... contact
        // distances beyond contact, the first start that overlaps no cluster sphere.
        const Vec3 u = d > 0.0 ? Vec3((x[j] - x[i]) / d) : Vec3(Vec3::UnitX());
        Vec3 from = x[i] + 3.0 * touch * u;
        for (double out = 2.0 * touch; out <= 64.0 * touch && overlaps_cluster(j, from); out *= 2.0) from = x[i] + (touch + out) * u;
        x[j] = slide(j, from, i);
      }
      ++out.moved;
    }
    grid.insert(j, x[j]);
  }
  return out;
}

}  // namespace cpc

ParamSpec<CpcFillersGenerator::Params> CpcFillersGenerator::spec() {
  using P = Params;
  ParamSpec<P> s("cpc_fillers", "generator",
                 "seed 002 filler configuration: monodisperse spheres at volume fraction phi uniform in the cube [0, L]^3, "
                 "overlaps removed by the paper's contact algorithm (gradient descent, step 0.4, largest relative overlap "
                 "<= 1e-3, open box), optional aggregation (segregated dispersions, lambda in radii); creates the box planes; "
                 "the stage then runs frozen (network modules only)");
  s.add("radius", &P::radius).unit("m").positive().doc("filler radius R (configs use 1: lengths in units of R)");
  s.add("box_length", &P::box_length).unit("m").positive().doc("cube edge L (paper: 70 R; 60 and 80 R for finite size)");
  s.add("volume_fraction", &P::volume_fraction).unit("1").range(1e-6, 0.6).doc("phi = N 4/3 pi R^3 / L^3 (N rounded)");
  s.add("aggregation_lambda", &P::aggregation_lambda)
      .unit("1")
      .nonnegative()
      .doc("lambda of the aggregation step in units of R (paper's segregated case: 35); 0 = homogeneous, no aggregation");
  s.add("step", &P::step).unit("1").range(1e-6, 0.999).doc("gamma of the contact algorithm (paper: 0.4)");
  s.add("overlap_tolerance", &P::overlap_tolerance)
      .unit("1")
      .positive()
      .doc("stop at largest relative overlap 1 - r_ij/(R_i+R_j) <= this (paper: 1e-3)");
  s.add("contact_tolerance", &P::contact_tolerance)
      .unit("1")
      .nonnegative()
      .doc("aggregation: pairs with gap <= this x (R_i + R_j) form the contact graph (paper: 1e-3)");
  s.add("max_iterations", &P::max_iterations).min(1).doc("largest number of gradient steps per contact-algorithm run (SetupError beyond)");
  s.add("material", &P::material).nonnegative().doc("material index (its density gives the masses)");
  return s;
}

double CpcFillersGenerator::estimated_particles() const {
  return std::round(p_.volume_fraction * std::pow(p_.box_length, 3) / (4.0 / 3.0 * kPi * std::pow(p_.radius, 3)));
}

void CpcFillersGenerator::generate(State& s) {
  if (p_.material < 0 || p_.material >= static_cast<std::int64_t>(s.materials.size()))
    throw ConfigError("/material", "material index " + std::to_string(p_.material) + " is not defined (" +
                                       std::to_string(s.materials.size()) + " materials)");
  if (s.particles.size() != 0)
    throw SetupError("cpc_fillers: the state already holds particles; the generator builds a configuration from scratch");
  const auto t0 = std::chrono::steady_clock::now();
  const double L = p_.box_length, R = p_.radius;
  const auto n = static_cast<std::size_t>(estimated_particles());
  std::vector<Vec3> x(n);
  const std::vector<double> r(n, R);
  for (auto& p : x)
    for (int d = 0; d < 3; ++d) p[d] = L * uniform_open01(s.rng);
  auto relax = [&](const char* what) {
    const cpc::OverlapRemoval o = cpc::remove_overlaps(x, r, p_.step, p_.overlap_tolerance, p_.max_iterations);
    if (!o.converged)
      throw SetupError(std::string("cpc_fillers: the contact algorithm (") + what + ") did not reach the overlap tolerance in " +
                       std::to_string(p_.max_iterations) + " iterations (largest relative overlap " + std::to_string(o.max_overlap) +
                       "); raise max_iterations or lower volume_fraction");
    return o;
  };
  const cpc::OverlapRemoval first = relax("initial");
  result_["contact_iterations"] = static_cast<double>(first.iterations);
  if (p_.aggregation_lambda > 0.0) {
    const cpc::Aggregation a = cpc::aggregate(x, r, p_.aggregation_lambda, p_.contact_tolerance, s.rng);
    const cpc::OverlapRemoval second = relax("after aggregation");
    result_["aggregation_seed_cluster"] = static_cast<double>(a.seed_cluster);
    result_["aggregation_examined"] = static_cast<double>(a.examined);
    result_["aggregation_moved"] = static_cast<double>(a.moved);
    result_["contact_iterations_after_aggregation"] = static_cast<double>(second.iterations);
  }
  const double rho = s.materials[p_.material].density;
  for (std::size_t i = 0; i < n; ++i) s.particles.add(x[i], R, rho * 4.0 / 3.0 * kPi * R * R * R, static_cast<std::int32_t>(p_.material));
  for (const auto& [name, point, normal] : {std::tuple{"xlo", Vec3(0, 0, 0), Vec3(1, 0, 0)},
                                            {"xhi", Vec3(L, L, L), Vec3(-1, 0, 0)},
                                            std::tuple{"ylo", Vec3(0, 0, 0), Vec3(0, 1, 0)},
                                            {"yhi", Vec3(L, L, L), Vec3(0, -1, 0)},
                                            std::tuple{"bottom", Vec3(0, 0, 0), Vec3(0, 0, 1)},
                                            {"top", Vec3(L, L, L), Vec3(0, 0, -1)}}) {
    if (s.find_wall(name)) throw SetupError(std::string("a wall named '") + name + "' already exists; cpc_fillers creates it");
    Wall w;
    w.name = name;
    w.shape = PlaneShape{point, normal};
    s.walls.push_back(std::move(w));
  }
  s.marks["cpc_fillers/box_length"] = L;
  result_["particles"] = static_cast<double>(n);
  result_["volume_fraction"] = static_cast<double>(n) * 4.0 / 3.0 * kPi * R * R * R / (L * L * L);
  result_["max_relative_overlap"] = cpc::max_relative_overlap(x, r);
  result_["generation_wall_time_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void CpcFillersGenerator::configure_stage(StageConfig& cfg) const {
  cfg.mechanics = false;  // rigid fillers in their final configuration: only the network modules run
}

std::map<std::string, double> CpcFillersGenerator::report(const State& s) const {
  auto r = result_;
  r["particles"] = static_cast<double>(s.particles.size());
  return r;
}

}  // namespace sparkdem::physics
