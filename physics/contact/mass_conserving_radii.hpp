#pragma once
/// # mass_conserving_radii — radius growth that keeps each sintered particle's volume (Arzt)
///
/// In a sintering DEM the centres of two necked particles approach and the lens between their
/// spheres stands for material that diffused into the neck. Without a correction that material is
/// counted twice: the union of the spheres stops densifying (seed 000's NiAl compact keeps a union
/// porosity of 0.25 while its porosity by mass reaches 0.05) and a region can reach a mass porosity
/// below zero. Arzt's geometric model (Acta Metall. 30 (1982) 1883; Fischmeister & Arzt, Powder
/// Metall. 26 (1983) 82) redistributes the volume cut off by the contact planes over the free
/// surface, so every particle grows. This module does it particle by particle, the local DEM form
/// recommended in ../shared/physics/review-2026-11-misses.md §1.4:
///
///   V_i(R_i) = 4/3 pi R_i^3 - sum_j V_cap(R_i, R_i - x_ij) = 4/3 pi r_i^3          (1)
///   x_ij = (d_ij^2 + R_i^2 - R_j^2) / (2 d_ij)           the radical plane of the pair
///   V_cap(R, h) = pi h^2 (3 R - h) / 3                   a cap of height h, 0 <= h <= 2R
///
/// r_i the particle's free radius (its mass over its density, thermally expanded), R_i the grown
/// radius it takes, d_ij the centre distance; the sum runs over the pairs that carry a sintered neck
/// (contact-law state `neck_radius` > 0) and overlap: an elastic overlap without a neck moves no
/// matter. The radical plane is where the two spheres' surfaces meet, so the union of the grown
/// spheres holds exactly sum_i 4/3 pi r_i^3 as long as no three spheres share a point (triple
/// overlaps are counted twice; this is the model's approximation).
/// dV_i/dR_i = 4 pi R^2 - sum_j [pi h^2 + pi h (2R - h)(1 - R/d)] = A_free + sum_j pi a_j^2 R/d > 0
/// (a_j^2 = h (2R - h), the cap's base), so (1) has at most one root; it is found by a Newton
/// iteration held inside [r_i, max_growth r_i]. A particle whose truncated sphere cannot reach its
/// volume below max_growth r_i (its free surface gone, over-densified) keeps max_growth r_i and is
/// counted (column `growth_capped`). The neighbours' radii are those of the previous sweep (Jacobi
/// sweeps from the last call's radii), repeated until no radius changes by more than
/// `sweep_tolerance` x its free radius. The sweeps converge slowly where a particle's surface is
/// mostly neck (its growth then follows its neighbours' almost one for one): two fixed sweeps left
/// the union 0.4 % off the free volume on the test cluster after 7 % of growth.
///
/// The growth of a pair, dR_i + dR_j, is added to its viscous approach u_s and to the law's
/// remembered radius sum (review §1.4, "implementation trap"): the elastic approach h - u_s and the
/// law's approach rate are unchanged, so growth is flow, not a load, and creates no repulsion.
///
/// Full density: a particle whose surface is all neck has no pore left to shrink into. The module
/// writes each particle's closed surface share c_i = min(1, sum_j h_j / (2 R_i)) (the caps' curved
/// area 2 pi R h over 4 pi R^2; field `mass_conserving_radii/closed_surface`) and flags the particle
/// dense once c_i >= dense_closed_surface (field `mass_conserving_radii/dense`, 1 or 0); the
/// sintering law's `stop_flow_at_dense` stops a dense particle's pairs flowing (the exact-geometry
/// form of seed 000's Eq. 22-23 grain-boundary fraction stop).
/// A dense particle keeps its radius: once closed its truncated volume is its Laguerre cell's, which
/// no radius sets (adding one constant to the R^2 of a closed cluster moves none of its planes), and
/// the sweeps stalled there (200 sweeps short of 1e-12 on the 300-particle NiAl compact at porosity
/// 0.20). What the model does not hold: a dense particle is not incompressible. A neighbour that
/// grows moves their radical plane toward it and takes its volume (column growth_missing_volume);
/// loading the pair's spring with that growth instead (lagged by a step) rings: the growth a closed
/// particle needs per unit of approach exceeds one, and the test cluster flipped by 1e-11 m every
/// step without decay.

/// State: the particle field `mass_conserving_radii/factor` g_i = R_i / r_i (checkpointed, kept
/// by later stages); thermal expansion (physics/thermal/expansion.hpp) multiplies the expanded
/// radius by it, so radius = r_i g_i whichever module wrote last. The compact monitor's porosities
/// by mass use r_i = radius / g_i.
///
/// Use with a sintering law whose neck follows the grown spheres (`neck`: "intersection", the
/// circle where the grown spheres meet; or kratos / coble). Do not combine it with the constant-
/// volume collar (`neck`: "cv"), which is the seed's own pair-wise volume device: the volume would
/// be counted twice (review §1.4). Not a model of seed 000 (which has no growth): an option beside it.
///
/// | parameter   | unit | meaning                                                            |
/// |-------------|------|--------------------------------------------------------------------|
/// | max_sweeps  | 1    | most Jacobi sweeps per call (a call that needs more is an error)   |
/// | sweep_tolerance | 1 | largest radius change of the last sweep / free radius            |
/// | max_growth  | 1    | largest R_i / r_i (a fully enclosed particle stops there)          |
/// | tolerance   | 1    | relative volume error of (1) at which a particle's Newton stops    |
/// | dense_closed_surface | 1 | closed surface share at which a particle is dense (1: all of it) |
///
/// Columns: growth_mean, growth_max (R / r over the particles), growth_capped (particles at
/// max_growth), growth_sweeps (sweeps of the last call), growth_dense (dense particles),
/// growth_missing_volume (the volume the truncated spheres lack, dense and capped ones, over all
/// the particles' volume: 0 while Eq. (1) holds everywhere).
#include <cstddef>
#include <string>
#include <vector>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

namespace kernel {

/// Volume of a spherical cap of height h (0 <= h <= 2R) on a sphere of radius R [m^3]:
/// V = pi h^2 (3R - h) / 3.
inline double cap_volume(double R, double h) { return 3.14159265358979323846 * h * h * (3.0 * R - h) / 3.0; }

/// Distance from the centre of sphere i to the radical plane of spheres (r_i, r_j) whose centres
/// are d apart [m]: x = (d^2 + r_i^2 - r_j^2) / (2 d) (where the two surfaces meet when they overlap).
inline double radical_distance(double d, double r_i, double r_j) { return (d * d + r_i * r_i - r_j * r_j) / (2.0 * d); }

/// One neighbour of a truncated sphere: its centre distance d [m] and radius r [m].
struct CapNeighbour {
  double d;
  double r;
};

/// Eq. (1) of the module at radius R: the volume of the sphere less its caps on the radical planes
/// of its neighbours, and dV/dR (the neighbours' radii held).
struct TruncatedVolume {
  double volume;        ///< [m^3]
  double dvolume;       ///< dV/dR [m^2]
  double closed = 0.0;  ///< sum of h / (2R) over the caps: their curved area 2 pi R h over 4 pi R^2 [1]
};
TruncatedVolume truncated_volume(double R, const CapNeighbour* nb, std::size_t n);

/// The radius R in [r_lo, r_hi] at which truncated_volume(R) = v0 (Newton held in the bracket);
/// r_hi with `capped` set when even r_hi leaves the volume short. `rel_tol` on the volume.
double conserving_radius(double v0, double r_start, double r_lo, double r_hi, const CapNeighbour* nb, std::size_t n,
                         double rel_tol, bool& capped);

}  // namespace kernel

struct NeckAdjacency;

class MassConservingRadii final : public Module {
 public:
  struct Params {
    std::int64_t max_sweeps = 200;
    double sweep_tolerance = 1e-12;
    double max_growth = 1.5;
    double tolerance = 1e-12;
    double dense_closed_surface = 1.0;
  };
  static ParamSpec<Params> spec();
  explicit MassConservingRadii(const Params& p) : p_(p) {}
  std::string name() const override { return "mass_conserving_radii"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void advance(State& s, const StepInfo& step) override;
  std::vector<std::string> columns() const override {
    return {"growth_mean", "growth_max", "growth_capped", "growth_sweeps", "growth_dense", "growth_missing_volume"};
  }
  std::vector<double> column_values(const State& s) const override;

  /// Grow every particle's radius to Eq. (1) and shift the sintered pairs' viscous approach by
  /// their growth (the whole of advance; exposed for the tests).
  struct Growth {
    std::int64_t capped = 0;  ///< particles at max_growth
    std::int64_t sweeps = 0;  ///< Jacobi sweeps taken
    std::int64_t dense = 0;   ///< dense particles after the call
    double missing_volume = 0.0;  ///< volume the truncated spheres miss / the particles' volume (dense or capped ones)
  };
  Growth grow(State& s) const;
  void visit(Archive& ar, const std::string& prefix) override {
    ar.visit(prefix + "/capped", last_.capped);
    ar.visit(prefix + "/sweeps", last_.sweeps);
    ar.visit(prefix + "/dense", last_.dense);
    ar.visit(prefix + "/missing_volume", last_.missing_volume);
  }

 private:
  /// Jacobi sweeps of Eq. (1) from the radii R until no radius changes by sweep_tolerance; dense
  /// particles keep their radius.
  std::vector<double> solve_radii(const NeckAdjacency& a, const std::vector<double>& r_free, std::vector<double> R,
                                  const std::vector<double>& dense, Step step, Growth& out) const;
  Params p_;
  Growth last_;  ///< of the last call
};

}  // namespace sparkdem::physics
