#pragma once
/// The packing generators of the source papers, plus a lattice for the LAMMPS pour scene.
///   lattice  simple-cubic lattice points k*a inside a box (LAMMPS `lattice sc` + `create_atoms`)
///   deposit  seed 000: loose random insertion in a wide cylinder, fall under gravity while the
///            cylinder contracts, until a target packing density (settled, small overlaps)
///   fill     seed 001 (GranOO "cooker"): radii uniform +-spread about
///            r = (phi V / (4/3 pi N))^(1/3) (Eq. 1, phi = 0.63), random insertion at reduced
///            size, frictionless growth to the size giving the target density, then settling
///   relax    seed 003: minimise U = sum w(q), w(q) = k (q - 1) ln q for q = d/(r_i + r_j) < 1
///            (and q = d/r_i against walls) with FIRE from an overlapping random start; radii
///            uniform in r(1 +- spread), or drawn from a size distribution (kept as drawn)
/// Container walls created: deposit -> "die" (cylinder) + "bottom" (plane);
/// fill and relax -> "die" + "bottom" + "top" (cylinder) or "xlo","xhi","ylo","yhi","bottom","top" (box).
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "engine/model/generator.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/packing/packing_common.hpp"

namespace sparkdem::physics {

/// Walls a fill or relax container may have: "die", "bottom", "top" (cylinder) or "xlo", "xhi",
/// "ylo", "yhi", "bottom", "top" (box); the union, as the shape is known only after binding.
inline std::vector<std::string> container_wall_names() { return {"die", "bottom", "top", "xlo", "xhi", "ylo", "yhi"}; }

class LatticeGenerator final : public Generator {
 public:
  struct Params {
    Vec3 lo = Vec3::Zero();  ///< [m]
    Vec3 hi = Vec3::Ones();  ///< [m]
    double spacing = 1.0;    ///< [m]
    double diameter = 0.5;   ///< [m]
    std::int64_t material = 0;
  };
  static ParamSpec<Params> spec();
  explicit LatticeGenerator(const Params& p) : p_(p) {}
  static std::vector<std::string> created_walls() { return {}; }
  std::string name() const override { return "lattice"; }
  void generate(State& s) override;
  double estimated_particles() const override;
  /// At most 1e9 particles; every centre inside every wall: up to kCheapParticles by a scratch
  /// generation in the scene's walls, above by the lattice's 8 corners (the walls are convex).
  void validate(const State& scene, std::vector<Diagnostic>& errors) const override;
  /// `sparkdem check` generates a lattice of up to kCheapParticles (to set up the stages after it);
  /// a larger one (1e6 particles take about 0.5 s) is left out like a relaxation.
  bool cheap_to_generate() const override { return estimated_particles() <= kCheapParticles; }
  static constexpr double kCheapParticles = 2e5;
  std::map<std::string, double> report(const State& s) const override;

 private:
  /// The lattice's index range a..b per axis (ConfigError "/lo", "/hi" when out of int64 range).
  void index_range(std::array<std::int64_t, 3>& a, std::array<std::int64_t, 3>& b) const;
  void check_corners(const State& scene, std::vector<Diagnostic>& errors) const;
  Params p_;
};

class DepositGenerator final : public Generator {
 public:
  struct Params {
    SizeDistributionParams size_distribution;
    double container_radius = 61.8e-6;   ///< final die radius [m]
    double container_height = 202e-6;    ///< bed height that sets the amount of powder [m]
    double target_density = 0.65;        ///< [1] tap density to reach
    std::int64_t particles = 0;          ///< 0: as many as fill target_density * pi R^2 H
    double initial_radius_factor = 1.5;  ///< [1] die radius at insertion / final radius
    double insertion_density = 0.25;     ///< [1] solid fraction of the loose insertion column
    double settle_time = 2e-4;           ///< [s] fall and settling before the die contracts
    double contraction_time = 2e-4;      ///< [s] time for the die to reach container_radius
    double min_radius_factor = 0.9;      ///< [1] smallest die radius / container_radius
    double gravity = 9.81e4;             ///< [m/s^2] packing gravity (scaled; reported)
    double ke_per_mass_below = 1e-8;     ///< [J/kg] settled when kinetic energy / mass is below
    double max_overlap = 0.01;           ///< [1] largest overlap / smaller radius allowed
    double damping_rate = 0.0;           ///< [1/s] background drag during settling (0 = off)
    std::int64_t material = 0;
  };
  static ParamSpec<Params> spec();
  explicit DepositGenerator(const Params& p) : p_(p) {}
  std::string name() const override { return "deposit"; }
  void generate(State& s) override;
  static std::vector<std::string> created_walls() { return {"die", "bottom"}; }
  bool steps() const override { return true; }
  void configure_stage(StageConfig& cfg) const override;
  std::vector<std::unique_ptr<Module>> modules() const override;
  std::vector<std::unique_ptr<Monitor>> monitors() const override;
  double estimated_particles() const override;
  std::map<std::string, double> report(const State& s) const override;
  std::vector<int> coordination_histogram(const State& s) const override { return packing_histogram(s); }

 private:
  Params p_;
  std::map<std::string, double> sampling_;
};

class FillGenerator final : public Generator {
 public:
  struct Params {
    std::string shape = "cylinder";        ///< cylinder | box
    double radius = 1e-3;                  ///< [m] cylinder radius
    double length = 5e-3;                  ///< [m] cylinder length (along z, from z = 0)
    Vec3 lo = Vec3::Zero();                ///< [m] box
    Vec3 hi = Vec3::Ones() * 1e-3;         ///< [m] box
    std::int64_t particles = 5000;         ///< N_DE
    double mean_radius = 0.0;              ///< [m] 0 = Eq. (1) from N and target_density
    double spread = 0.125;                 ///< [1] radii uniform in r(1 +- spread)
    double target_density = 0.63;          ///< [1]
    double initial_scale = 0.5;            ///< [1] radii at insertion / final radii
    double growth_time = 0.0;              ///< [s] 0 = 2000 steps of the stage
    double damping_rate = 0.0;             ///< [1/s] background drag (0 = off)
    double ke_per_mass_below = 1e-10;      ///< [J/kg]
    double max_overlap = 0.01;             ///< [1]
    double neighbour_gap_relative = -1.0;  ///< [1] of r_mean: report seed 001's microstructure (< 0: off)
    std::int64_t material = 0;
  };
  static ParamSpec<Params> spec();
  /// Throws ConfigError ("/particles") when a given mean_radius makes the radii overfill the
  /// container (solid fraction above 0.74, the densest sphere packing).
  explicit FillGenerator(const Params& p);
  std::string name() const override { return "fill"; }
  void generate(State& s) override;
  static std::vector<std::string> created_walls() { return container_wall_names(); }
  bool steps() const override { return true; }
  void configure_stage(StageConfig& cfg) const override;
  std::vector<std::unique_ptr<Module>> modules() const override;
  std::vector<std::unique_ptr<Monitor>> monitors() const override;
  double estimated_particles() const override { return static_cast<double>(p_.particles); }
  std::map<std::string, double> report(const State& s) const override;
  std::vector<int> coordination_histogram(const State& s) const override { return packing_histogram(s); }
  std::map<std::string, std::vector<double>> report_arrays(const State& s) const override {
    return packing_arrays(s, p_.neighbour_gap_relative);
  }
  double formula_mean_radius() const;
  /// Density the packing must reach: target_density, or the one implied by a given mean_radius.
  double expected_density() const;
  double container_volume() const;

 private:
  Params p_;
  double growth_scale_ = 1.0;
};

class RelaxGenerator final : public Generator {
 public:
  struct Params {
    std::string shape = "box";      ///< box | cylinder
    Vec3 lo = Vec3::Zero();         ///< [m] box
    Vec3 hi = Vec3::Ones() * 1e-3;  ///< [m] box
    double radius = 5e-4;           ///< [m] cylinder radius (axis z through the origin)
    double length = 1e-3;           ///< [m] cylinder length along z from z = 0
    /// type "none": radii uniform in r(1 +- spread); otherwise diameters drawn from it, unscaled
    SizeDistributionParams size_distribution = no_size_distribution();
    std::int64_t particles = 1000;  ///< with a size distribution, 0 = fill target_density * V
    double target_density = 0.6;    ///< [1] solid volume / container volume
    double spread = 0.125;          ///< [1] radii uniform in r(1 +- spread)
    double stiffness = 1.0;         ///< [J] k of w(q) (the minimum does not depend on it)
    std::int64_t max_iterations = 200000;
    double force_tolerance = 1e-6;         ///< [1] stop when max |F| < tol k / r_mean
    double max_step = 0.05;                ///< [1] largest displacement per iteration / radius
    double max_overlap = 0.0;              ///< [1] also stop when max overlap / smaller radius <= this (0 = off)
    double density = 1000.0;               ///< [kg/m^3] particle density for the masses (not read from materials)
    double neighbour_gap_relative = -1.0;  ///< [1] of r_mean: report seed 001's microstructure (< 0: off)
    std::int64_t material = 0;
    /// [1] solid fraction more than 4 mean diameters from every face to reach by rescaling the radii
    /// (and masses) and relaxing again (0: off; target_density then only sets the first radii)
    double interior_target_density = 0.0;
    double interior_tolerance = 0.001;   ///< [1] |interior fraction - target| at which the rounds stop
    std::int64_t interior_rounds = 8;    ///< most rescale-and-relax rounds (more: a set-up error)
  };
  static ParamSpec<Params> spec();
  explicit RelaxGenerator(const Params& p) : p_(p) {}
  std::string name() const override { return "relax"; }
  bool cheap_to_generate() const override { return false; }  // FIRE minimisation
  void generate(State& s) override;
  static std::vector<std::string> created_walls() { return container_wall_names(); }
  double estimated_particles() const override;
  double container_volume() const;
  std::map<std::string, double> report(const State& s) const override;
  std::vector<int> coordination_histogram(const State& s) const override { return packing_histogram(s); }
  std::map<std::string, std::vector<double>> report_arrays(const State& s) const override {
    return packing_arrays(s, p_.neighbour_gap_relative);
  }

 private:
  /// Radii: uniform spread rescaled to exactly target_density (no distribution), else drawn.
  std::vector<double> radii(State& s);
  /// The drawn particles at random centres in the container, and its walls.
  void place(State& s, const std::vector<double>& radii) const;
  /// FIRE on U over the particles from index `first` (and the walls) until converged; its figures into result_.
  void relax(State& s, std::size_t first);
  /// Rescale-and-relax rounds until the solid fraction 4 mean diameters in from every face is
  /// interior_target_density (interior_target_density > 0).
  void reach_interior_target(State& s, std::size_t first);
  Params p_;
  std::map<std::string, double> result_;
  std::map<std::string, double> sampling_;
  double scale_radius_ = 0.0;  ///< [m] length scale of the FIRE step, skin and force tolerance
};

/// Radius growth used by `fill`: r_i(t) = r_i,final * s(t), s rising linearly from s0 to s1
/// over the growth time, then constant; masses follow r^3 at constant density. Growth pauses
/// while the largest pair overlap / smaller radius of the last contact pass exceeds
/// `halt_overlap` (0 = never): a jammed packing is not squeezed further.
class RadiusGrowth final : public Module {
 public:
  struct Params {
    double s0 = 0.5, s1 = 1.0;  ///< [1]
    double duration = 1.0;      ///< [s]
    double halt_overlap = 0.0;  ///< [1]
  };
  static ParamSpec<Params> spec();
  explicit RadiusGrowth(const Params& p) : p_(p) {}
  std::string name() const override { return "radius_growth"; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  void advance(State& s, const StepInfo& step) override;

 private:
  Params p_;
};

}  // namespace sparkdem::physics
