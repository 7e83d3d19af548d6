#pragma once
/// # ptc_matrix — thermoelastic bonded-network matrix for rigid fillers (seed 002, minimum model)
///
/// Source: Barbieri et al., "Pyroresistive response of percolating conductive polymer
/// composites", §II.3 and SM S4 (thermal eigenstrain eps_TH = eps0 (1,1,1,0,0,0) in the polymer,
/// rigid non-expanding spheres); /work/shared/physics/cpc-and-networks.md §1.2 (linearity),
/// §1.3 (connection rule), §1.6 (the table "The thermoelastic part: options": the recommended
/// minimum, rigid spheres + the matrix as a bonded network). This file is that minimum model,
/// not the paper's RKPM continuum.
///
/// MODEL. Fillers i (centre x_i [m], radius R_i [m]) are rigid and carry only a translation
/// u_i [m] (no rotations, as in S15). Every pair with polymer gap
///     h_ij = |x_j - x_i| - R_i - R_j <= h_max                              (cut-off, [m])
/// is joined by an axial spring along n_ij = (x_j - x_i)/|x_j - x_i| of stiffness
///     k_ij = E_m A / max(h_ij, h_min)                                      [N/m]
/// (a polymer column of cross-section A [m^2] and length max(h, h_min): a thin polymer layer is
/// stiff, h_min caps the stiffness of touching and overlapping pairs) and eigen-elongation
///     e_ij = eps0 h*_ij,  h*_ij = h_ij if h_ij > touch_gap_rel D_ij, else 0  [m]
/// (only the polymer expands; the gap of a touching pair holds no polymer, so no eigenstrain).
/// Energy W(u) = 1/2 sum_ij k_ij (n_ij . (u_j - u_i) - e_ij)^2 (linearised kinematics: small
/// eps0). Stationarity gives the sparse symmetric positive semi-definite system
///     K u = eps0 f,  K = sum_ij k_ij B_ij^T B_ij,  f = sum_ij k_ij h*_ij B_ij^T,
/// B_ij u = n_ij . (u_j - u_i). The problem is linear in eps0, so ONE solve for eps0 = 1 gives
/// u_hat and the unit opening of every pair, delta_ij = n_ij . (u_hat_j - u_hat_i) [m per unit
/// eps0]; at strain eps0 the gap is h_ij + eps0 delta_ij.
///
/// Since every k_ij is proportional to E_m A, u_hat does NOT depend on E_m or A: only the ratios
/// of the gaps, h_min and h_max matter (E_m, A set the stored energy only).
///
/// NO POISSON RATIO. Axial (central-force) springs carry no shear or bending, so the matrix has
/// no independent Poisson ratio: nu is whatever the geometry of the network gives (for an affine
/// central-force network the Cauchy relation gives nu = 1/4). The paper does not give nu either
/// (note §1.2); the continuum model of the issue defaults to 0.35. Tuning nu needs shear springs
/// or beams (not done here).
///
/// RIGID-BODY AND FLOPPY MODES. Free expansion (the note's natural choice, §1.2): no filler is
/// held unless `fixed` lists some (u = 0 there; used by the closed-form chain tests). K is
/// singular on rigid-body modes, on isolated fillers and, for a sparse axial network, on floppy
/// modes. The right-hand side f lies in the range of B^T, orthogonal to the null space of K
/// (every null vector z has B z = 0), and every reported opening is B u, blind to null vectors.
/// A ground spring delta x mean(k) on every free degree of freedom (`regularisation` = delta,
/// default 1e-9) makes the matrix SPD; it removes the null-space part of u (which carries no
/// opening) and perturbs the openings by a relative O(delta mean(k) / lambda_min+(K)).
/// Solver: Eigen SimplicialLDLT (AMD ordering), exact up to rounding.
///
/// LENGTHS ARE RELATIVE to the pair's contact distance D_ij = R_i + R_j (the filler diameter D
/// for equal fillers): h_max = cutoff_gap_rel D_ij, h_min = min_gap_rel D_ij, and the touch and
/// break thresholds below. The relative openings delta / D, hence every break and join strain, are
/// then invariant under a scaling of every length (the paper states its rule as 0.1 % of D;
/// absolute thresholds held only because R = 1 m).
///
/// CONNECTION RULE (note §1.3, §4 "break criterion"; the paper does not state it). The initial
/// contact set is the pairs with h_ij <= touch_gap_rel D_ij (the paper's 0.1 % of D; the same
/// set as contact_percolation). A touching contact conducts at eps0 while
///     h_ij + eps0 delta_ij <= max(break_gap_rel D_ij, h_ij),
/// i.e. it opens when its gap exceeds the break threshold; a contact that starts with a gap above
/// it (inside the touch tolerance) opens at its first positive opening. A pair that does not
/// touch at eps0 = 0 but lies within closing_gap_rel D_ij (a closing candidate) joins the network
/// once its gap closes to the touch threshold,
///     h_ij + eps0 delta_ij <= touch_gap_rel D_ij
/// (the paper: "new connections might be realized ... (negative strain)": on cooling, or where
/// the matrix squeezes two fillers together). Both are the half-line {eps0 : h + eps0 delta <= T}
/// with T = max(break_gap_rel D, h) (touching) or touch_gap_rel D (candidate): the contact
/// conducts for lo <= eps0 <= hi (conduction_intervals). A candidate joins at, and would leave at,
/// the touch threshold: the break threshold applies to the initial contact set only (with
/// break_gap_rel > touch_gap_rel a candidate already closer than break_gap_rel D still joins only at
/// touch_gap_rel D). For a touching contact with delta < 0, lo < 0 is where it opens on cooling.
/// Two readings of the break threshold:
///  - break_gap_rel = 0, the note's inference "the gap becomes positive" (the opening exceeds the
///    residual overlap). MEASURED on cpc_fillers at phi = 25 %, L = 70 R: about half of the
///    contact set (gap <= 0.1 % of D) ends the contact algorithm at a small POSITIVE gap, and
///    all of those with a positive opening break at once: Z falls from 1.58 to 0.88 at
///    eps0 = 0.5 % and the network no longer spans at any eps0 > 0 (switching strain 0);
///  - break_gap_rel = touch_gap_rel (the ptc_strain default): the same rule before and after
///    straining, "touching = gap <= 0.1 % of D"; eps0 = 0 reproduces contact_percolation.
/// Electrics: unit conductance per conducting contact, the whole network in one system with all
/// electrode fillers of a face at one potential (parallel spanning clusters: 1/R = sum 1/R_k),
/// rho = R_eq L. Z = 2 (conducting contacts) / N.
#include <span>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/graph/laplacian.hpp"

namespace sparkdem::physics::ptc {

struct MatrixParams {
  double matrix_modulus = 1.0;   ///< E_m [Pa]
  double bond_area = 1.0;        ///< A [m^2]
  double min_gap_rel = 5e-3;     ///< h_min / D_ij [1], > 0
  double cutoff_gap_rel = 0.5;   ///< h_max / D_ij [1]: springs between pairs with gap <= h_max
  double touch_gap_rel = 1e-3;   ///< touching: gap <= this x D_ij [1] (no eigenstrain; contact set)
  double regularisation = 1e-9;  ///< delta [1]: ground spring delta mean(k) on free DOFs
};

/// The spring network: pairs (a[e] < b[e]) with gap [m], unit normal a -> b and stiffness [N/m].
struct SpringNetwork {
  std::vector<Index> a, b;
  std::vector<double> gap;        ///< h_ij [m]
  std::vector<Vec3> normal;       ///< n_ij (from a to b)
  std::vector<double> stiffness;  ///< k_ij [N/m]
  std::vector<double> eigen_gap;  ///< h*_ij [m]: eigen-elongation per unit eps0
  std::vector<double> distance;   ///< D_ij = R_i + R_j [m]
  std::size_t size() const { return a.size(); }
};

/// Every pair of fillers with gap <= p.cutoff_gap_rel D_ij (and >= -(R_i + R_j): coincident centres are
/// a SetupError), sorted by (a, b).
SpringNetwork build_network(const std::vector<Vec3>& x, const std::vector<double>& r, const MatrixParams& p);

struct UnitSolution {
  std::vector<Vec3> displacement;  ///< u_hat_i [m per unit eps0]
  std::vector<double> opening;     ///< delta_e = n_e . (u_hat_b - u_hat_a) per spring [m per unit eps0]
  double residual = 0.0;           ///< ||K u - f|| / ||f|| of the regularised system [1] (0 if f = 0)
};
/// One sparse solve for eps0 = 1 on nodes 0..n-1; fillers in `fixed` are held at u = 0.
UnitSolution solve_unit(std::size_t n, const SpringNetwork& net, const MatrixParams& p, std::span<const Index> fixed = {});

/// The contacts that may conduct: the touching ones (the initial contact set) and the closing
/// candidates, with their initial gap and unit opening.
struct Contacts {
  std::vector<Index> a, b;
  std::vector<double> gap;       ///< h_ij at eps0 = 0 [m]
  std::vector<double> opening;   ///< delta_ij [m per unit eps0]
  std::vector<double> distance;  ///< D_ij = R_i + R_j [m]
  std::vector<char> touching;    ///< 1: in the initial contact set (gap <= touch_gap_rel D); 0: a closing candidate
  std::size_t size() const { return a.size(); }
  std::size_t touching_count() const;
};
/// Springs of net with gap <= max(touch_gap_rel, closing_gap_rel) D_ij, with the openings of sol
/// (closing_gap_rel = 0: the touching contacts only).
Contacts candidate_contacts(const SpringNetwork& net, const UnitSolution& sol, double touch_gap_rel, double closing_gap_rel);

/// The composite's volumetric strain read from the fillers: tr A of the least-squares affine fit
/// u_i ~ A x_i + b over every filler (A = C_ux C_xx^-1 with the centred covariances
/// C_ux = sum (u_i - u_mean)(x_i - x_mean)^T, C_xx = sum (x_i - x_mean)(x_i - x_mean)^T).
/// Per unit eps0 when u is a unit solution. Seed 002's Fig. 7 inset reads the effective volume
/// fraction phi_eff = phi / (1 + eps0 tr A) off it (the fillers' number density). Needs >= 4
/// fillers not on one plane (else SetupError).
double affine_volumetric_strain(const std::vector<Vec3>& x, const std::vector<Vec3>& u);

/// Per contact, the strains between which it conducts (header rule): lo <= eps0 <= hi [1], each
/// possibly infinite; an empty interval (a candidate that never closes) has lo = +inf, hi = -inf.
/// For a touching contact, hi is its break strain (+inf if it never opens under expansion).
struct Intervals {
  std::vector<double> lo, hi;
};
Intervals conduction_intervals(const Contacts& c, double touch_gap_rel, double break_gap_rel);

struct StrainPoint {
  double eps0 = 0.0;
  bool spanning = false;
  std::size_t conducting = 0;  ///< conducting contacts
  double coordination = 0.0;   ///< Z = 2 conducting / n [1]
  double resistance = 0.0;     ///< R_eq [Ohm] with unit_conductance per contact; +inf if not spanning
};
/// Connectivity and resistance at strain eps0 (one Kirchhoff solve if spanning).
StrainPoint evaluate(std::size_t n, const Contacts& c, const Intervals& iv, double eps0, double unit_conductance,
                     std::span<const Index> high, std::span<const Index> low, LaplacianSolver& solver);

/// The exact switching strain eps* >= 0: the network spans for every 0 <= eps0 <= eps* and fails
/// just above it. Contacts only break (hi) and join (lo) at their interval ends, so spanning can
/// fail only at a break strain: first the contacts that conduct from eps0 = 0 on are added in
/// decreasing hi (union-find) until the electrodes connect (eps1: without closing contacts the
/// answer); then each break strain above eps1 is checked in increasing order with the contacts
/// that joined by then, until one no longer spans. 0 if the initial network does not span; +inf
/// if it spans at every eps0 >= 0.
double switching_strain(std::size_t n, const Contacts& c, const Intervals& iv, std::span<const Index> high, std::span<const Index> low);

}  // namespace sparkdem::physics::ptc
