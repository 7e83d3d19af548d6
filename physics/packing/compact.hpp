#pragma once
/// Porosity of a powder compact in a die (seed 000's hot press, physics notes
/// sintering-electrical.md §5.2, §7.2): the stage key `"compact"` adds the CompactMonitor.
///
/// Solid volume of overlapping spheres in a region (compact_solid_volume):
///   V_s = sum_i V(sphere_i ∩ region) - sum_{overlapping pairs, lens centre in region} V_lens(r_i, r_j, d_ij)
/// * each sphere is clipped to the region exactly as in the packing density
///   (sphere_volume_in_region): the caps beyond the punch planes and the part beyond the die
///   radius (wall overlaps) are not solid of the compact;
/// * the lens (sphere–sphere overlap) of a pair is subtracted whole when its centre (the centre
///   of the intersection circle) lies in the region, else not at all. A lens cut by the region
///   boundary is therefore counted whole or not at all: an error of at most that lens volume,
///   which is second order in the overlap (V_lens ~ pi r delta^2 / 2 for equal spheres);
/// * triple overlaps (a point inside three spheres) are subtracted twice; they need overlaps of
///   the order of 10 % of the radius and are ignored.
/// Porosity = 1 - V_s / V_region. Pure functions on arrays; lengths in [m].
#include <array>
#include <string>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/simulation.hpp"
#include "engine/state/state.hpp"
#include "physics/packing/packing_metrics.hpp"

namespace sparkdem::physics {

/// Volume [m^3] of the lens common to two spheres of radii r_i, r_j [m] at centre distance d [m]:
///   V = pi (r_i + r_j - d)^2 (d^2 + 2 d r_j - 3 r_j^2 + 2 d r_i + 6 r_i r_j - 3 r_i^2) / (12 d)
/// for |r_i - r_j| < d < r_i + r_j (Weisstein, "Sphere-Sphere Intersection", MathWorld);
/// 0 for d >= r_i + r_j; 4/3 pi min(r_i, r_j)^3 for d <= |r_i - r_j| (one sphere inside the other).
double lens_volume(double ri, double rj, double d);

/// Centre of the lens [m]: the centre of the intersection circle, on the line from x_i to x_j at
/// a = (d^2 + r_i^2 - r_j^2) / (2 d) from x_i (the smaller sphere's centre when one sphere
/// contains the other).
Vec3 lens_centre(const Vec3& xi, double ri, const Vec3& xj, double rj);

/// V_s above [m^3]: spheres clipped to the region minus the lenses of the pairs in `pairs`
/// (candidate pairs, each unordered pair at most once; non-overlapping ones are skipped) whose
/// lens centre lies in the region.
double compact_solid_volume(const std::vector<Vec3>& positions, const std::vector<double>& radii,
                            const std::vector<std::array<Index, 2>>& pairs, const Region& region);
/// v [m^3] minus the lenses of those pairs whose lens centre lies in the region, in pair order:
/// compact_solid_volume = minus_lenses(solid_volume_in_region(...), ...), for a caller that also
/// needs the spheres' volume alone (the porosity by mass).
double minus_lenses(double v, const std::vector<Vec3>& positions, const std::vector<double>& radii,
                    const std::vector<std::array<Index, 2>>& pairs, const Region& region);

/// Stage key "compact": the die (a cylinder wall) and the two punches (plane walls normal to its
/// axis, normals pointing into the compact).
struct CompactParams {
  std::string die = "die";        ///< cylinder wall
  std::string bottom = "bottom";  ///< plane wall (lower punch)
  std::string top = "top";        ///< plane wall (upper punch)
  double interior_margin = 0.0;   ///< [m] interior region margin from every wall; 0 = one largest diameter
  double envelope_cell = 3.0;     ///< [mean diameters] caliper cells of porosity_envelope (envelope_volume)
};
ParamSpec<CompactParams> compact_spec();

/// The compact region: the die at its current radius (R_0 - u) between the two punch planes at
/// their current offsets; its height H is the distance between the planes along the die axis.
/// Throws SetupError when a wall is missing, has the wrong shape or the planes are not normal to
/// the axis or do not face each other.
CylinderRegion compact_region(const State& s, const CompactParams& p);

/// Volume [m^3] of a sample's own envelope, profiled like a caliper around it: the compact
/// region (height H between the punches, die radius R) is cut into n_z = max(1, round(H / c))
/// slices along the axis and n_t = max(4, round(2 pi R / c)) sectors about it, c = cell_diameters
/// x 2 r_mean (r_mean the mean particle radius); each (slice, sector) cell with a particle centre gets the outermost
/// extent of its particles, max (rho_i + r_i) (rho the distance from the axis); a slice's envelope
/// radius is the mean over its non-empty sectors, and V = sum over slices pi R_k^2 H / n_z (a
/// slice without particles adds nothing). Centres beyond the punches count in the end slices.
/// A single particle pinned at the die (e.g. by punch friction) moves one sector, not the whole
/// envelope; the sector mean is the surface a profilometer would average.
/// Cells must be large enough to hold a surface particle, else a cell's outermost particle is an
/// interior one and the envelope shrinks: on the reduced NiAl compact (314 particles, R = 3.4
/// d_mean) filling its die before densification, c = 1 / 2 / 3 mean diameters read 0.94 / 0.99 /
/// 1.005 of the die radius (CompactParams::envelope_cell = 3).
double envelope_volume(const std::vector<Vec3>& positions, const std::vector<double>& radii, const CylinderRegion& region,
                       double cell_diameters);

/// Time-series columns: porosity = 1 - V_s / (pi R^2 H); porosity_interior (the same in the
/// region shrunk by interior_margin from every wall); relative_density = 1 - porosity;
/// compact_height = H [m]; porosity_mass = 1 - sum_i V(sphere_i ∩ region) / (pi R^2 H) (free radii: the
/// mass-conserving growth of mass_conserving_radii left out, it holds no matter), the
/// lenses NOT subtracted: in a sintering compact the overlap stands for shrinkage and the lens
/// material sits in the neck, so this is the porosity by mass (Archimedes) — the one to compare
/// with measured samples; `porosity` (lenses subtracted) falls behind it as necks grow;
/// envelope_radius [m] = sqrt(V_env / (pi H)) with V_env = envelope_volume(), and
/// porosity_envelope = 1 - V_spheres / V_env (spheres clipped to the punches only, lenses not
/// subtracted: by mass, in the sample's own envelope): a sample that shrinks away
/// from the die wall on cooling is measured on its own size, as a sample taken out of the die
/// (issue 21 item 7); die_radius = R [m] (envelope_radius / die_radius: does the compact fill
/// its die?); porosity_mass_interior: porosity_mass of the interior region (core against
/// compact: a uniform densification has them equal; issue 36's quasi-static gates);
/// envelope_p995_radius [m]: the 99.5th percentile over particles of (distance from the die axis +
/// radius), linear between order statistics as numpy's percentile (issue 59's G2: does the pressed
/// compact stay on its die wall?). Overlapping pairs are found afresh from the current positions
/// (cell-grid search, O(N); deterministic order), so bonded pairs and pairs of any law count.
/// Registered as the monitor (stage key) "compact" in physics/register_all.cpp.
class CompactMonitor final : public Monitor {
 public:
  using Params = CompactParams;
  static ParamSpec<Params> spec() { return compact_spec(); }
  /// Throws ConfigError ("/top") when both punches are the same wall.
  explicit CompactMonitor(CompactParams p);
  std::vector<std::string> columns(const State& s) const override;
  std::vector<double> values(const State& s) const override;
  /// The die (a cylinder) and the two punches (planes).
  std::vector<WallUse> wall_uses() const override { return {{"die", p_.die, false}, {"bottom", p_.bottom, true}, {"top", p_.top, true}}; }

 private:
  CompactParams p_;
};

}  // namespace sparkdem::physics
