#pragma once
/// # ptc_strain — contact network of rigid fillers under a thermal eigenstrain of the matrix
///
/// Source: Barbieri et al. (seed 002) §II.3-4, SM S3-S4; /work/shared/physics/cpc-and-networks.md
/// §1.2-1.6. The model, its equations and the connection rule are in ptc_matrix.hpp (the note's
/// recommended minimum: rigid non-expanding fillers, the polymer as axial springs with
/// eigen-elongation eps0 h_ij between fillers within a gap cut-off, free expansion).
///
/// Two matrix models (`matrix_model`):
///  - "bonded" (default): the bonded network of ptc_matrix.hpp (parameters cutoff_gap_rel, min_gap_rel,
///    matrix_modulus, bond_area, regularisation);
///  - "rkpm": the paper's continuum (rkpm_matrix.hpp): meshless RKPM matrix over the smallest
///    cube holding the box [0, L]^3 (L = `length` or the cpc_fillers box edge) and every filler
///    (the contact algorithm has no walls: fillers may poke out), spheres bonded by the surface penalty
///    alpha = bond_penalty, free expansion (translation pinned at the box centre), one CG solve
///    for eps0 = 1 (parameters matrix_modulus, poisson_ratio, node_spacing, support_factor,
///    quadrature_order, cell_subdivision, surface_points, bond_penalty, pin_penalty,
///    cg_tolerance, cg_max_iterations, linear_solver). Column `springs` then holds the RKPM node count.
/// Both give the unit opening delta_ij = n_ij . (U_j - U_i) of every touching contact and closing
/// candidate; the rest
/// (break rule, Z, rho, switching strain, opening statistics) is common.
/// Use after a cpc_fillers stage (frozen mechanics: `"stop": {"steps": 0}`). On its event clock
/// (the stage's initial state, then after a move of 0.05 R_min or a broken bond) the module
///  1. builds the spring network (pairs with gap <= cutoff_gap_rel D_ij) and solves ONCE for eps0 = 1;
///  2. takes the touching contacts (gap <= touch_gap_rel D_ij, the contact_percolation set) and
///     the closing candidates (gap <= closing_gap_rel D_ij) with their unit openings; their
///     conduction intervals by the rule of ptc_matrix.hpp (break_gap_rel; a candidate joins when
///     its gap closes to touch_gap_rel D_ij);
///  3. for every eps0 in eps0_values: spanning, Z and rho = R_eq L (unit conductances, one
///     Kirchhoff solve each, all spanning clusters in parallel);
///  4. the exact switching strain: the end of the first spanning interval [0, eps*] (with closing
///     contacts the network may span again later).
/// Every threshold is relative to the pair's contact distance D_ij = R_i + R_j (the filler
/// diameter for equal fillers): a scene scaled in size keeps its switching strain. The retired
/// absolute keys (touch_tolerance, break_gap, cutoff_gap, min_gap [m]) are refused by name.
/// Columns (prefix ptc_strain_):
///   springs, contacts             number of springs / of touching contacts
///   closing_candidates            pairs within closing_gap_rel D that do not touch at eps0 = 0
///   switching_strain              exact switching strain [1]: the network spans on [0, it] and
///                                 fails just above (0: no spanning at eps0 = 0)
///   switching_strain_listed       first listed eps0 without spanning [1] (+inf if all span)
///   opening_mean, opening_median  contact opening at eps0 = opening_strain, in units of the
///                                 pair's contact distance R_i + R_j (= D), [1]; with the
///                                 closed-form linearity, eps0 x delta / D
///   opening_negative_fraction     fraction of contacts that close (delta < 0) [1]
///   solve_residual                ||K u - f|| / ||f|| of the unit solve [1]
///   strain_{total,mech}_mean, strain_{total,mech}_negative_fraction   (rkpm with
///                                 strain_statistics) volume means / fractions of the max
///                                 principal total strain sym(grad u) and mechanical strain
///                                 sym(grad u) - eps0 I at eps0 = opening_strain [1]; then, with
///                                 m + 1 >= 2 strain_histogram_edges, strain_{total,mech}_hist_<k>,
///                                 _below, _above: volume fractions per bin (the paper's Fig. 4),
///                                 over the points strain_points names (matrix, box, nodes)
///   composite_volumetric_strain   (rkpm with strain_statistics) eps0 tr A at eps0 = opening_strain
///                                 [1]: A the least-squares affine fit of the fillers'
///                                 displacements (ptc::affine_volumetric_strain); the effective
///                                 volume fraction of seed 002's Fig. 7 inset is phi / (1 + this)
///   opening_hist_<k>              (only if opening_histogram_edges has m + 1 >= 2 edges) the
///                                 fraction of contacts whose relative opening (as opening_mean)
///                                 lies in [edge_k, edge_k+1), k = 0..m-1, then
///                                 opening_hist_below / opening_hist_above (outside the edges)
///   spanning_<e>, coordination_<e>, resistivity_<e>   per listed eps0 (<e> = eps0 in percent
///                                 with 'p' for the point, e.g. 3p15pct); rho [Ohm m], +inf
///                                 when not spanning. Sweep CSVs write non-finite values as
///                                 nan: there nan resistivity = not spanning, nan
///                                 switching_strain_listed = spans at every listed eps0.
/// Temperature (optional; `temperatures` non-empty): eps0(T) from the matrix expansion law of
/// physics/electrical/ptc_temperature.hpp (expansion_coefficient alpha_s, optional melting step
/// at melting_temperature with strain jump melting_strain over melting_width and
/// expansion_coefficient_melt above it). The response is linear in eps0, so rho(T) = rho(eps0(T))
/// from the same single solve. Extra columns:
///   switching_temperature         T(eps*) [K]: the temperature at which eps0(T) reaches the exact
///                                 switching strain (inverse of eps0(T); inside a sharp jump: T_m);
///                                 +inf if the network never switches
///   eps0_<T>, spanning_<T>, coordination_<T>, resistivity_<T>   per listed T (<T> = T in K with
///                                 2 decimals and 'p' for the point, e.g. T403p15K)
/// Per-contact output (frames, /networks/ptc_contacts): every touching contact and closing
/// candidate: ids, initial gap [m], unit opening delta [m per unit eps0], the strains it conducts
/// between (break_strain = hi, join_strain = lo [1], ptc_matrix.hpp), touching (1) or candidate (0).
/// Parameter choices (configs/cpc_ptc_strain.json): h_max = 0.5 D = 1 R (centre distance <= 3 R:
/// about 6 neighbours per filler at phi = 25 %, near the isostatic 6 of axial springs in 3-D:
/// floppy modes exist and the regularisation handles them), h_min = 0.05 D = 0.1 R. h_min sets the stiffness of the springs
/// of touching pairs relative to the expanding gaps, hence how far contacts open: it controls
/// the switching strain (see the config description); E_m and A cancel.
#include <cstdint>
#include <string>
#include <vector>

#include "engine/graph/laplacian.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/electrical/ptc_temperature.hpp"

namespace sparkdem::physics {

class PtcStrain final : public Module {
 public:
  struct Params {
    std::string high = "x_lo";
    std::string low = "x_hi";
    double touch_gap_rel = 1e-3;    ///< [1] of D_ij = R_i + R_j: touching when the gap is <= this x D_ij (paper 0.1 % of D)
    double break_gap_rel = 1e-3;    ///< [1] of D_ij: a contact opens when its gap exceeds this x D_ij (default = touch_gap_rel)
    double closing_gap_rel = 0.05;  ///< [1] of D_ij: pairs within this gap may close and join (0: none)
    double cutoff_gap_rel = 0.5;    ///< [1] of D_ij: h_max (bonded)
    double min_gap_rel = 5e-3;      ///< [1] of D_ij: h_min (bonded)
    double matrix_modulus = 1.0;    ///< [Pa] E_m (openings do not depend on it)
    double bond_area = 1.0;         ///< [m^2] A (openings do not depend on it)
    double regularisation = 1e-9;   ///< [1]
    double unit_conductance = 1.0;  ///< [S]
    double length = 0.0;            ///< [m] 0: cpc_fillers box edge
    double opening_strain = 0.01;   ///< [1] eps0 of the opening statistics
    std::vector<double> eps0_values = {0.0, 0.005, 0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.05};
    // temperature (ptc_temperature.hpp); empty temperatures: off
    std::vector<double> temperatures;             ///< [K]
    double expansion_coefficient = 2e-4;          ///< alpha_s [1/K] (matrix - filler mismatch)
    double expansion_coefficient_melt = 0.0;      ///< alpha_l [1/K]; 0 = alpha_s
    double reference_temperature = 293.15;        ///< [K] eps0 = 0
    double melting_temperature = 0.0;             ///< T_m [K]; 0 = no melting step
    double melting_strain = 0.0;                  ///< Delta_m [1]
    double melting_width = 0.0;                   ///< [K]
    std::vector<double> opening_histogram_edges;  ///< [1] relative-opening bin edges (empty: no histogram)
    std::string matrix_model = "bonded";          ///< "bonded" | "rkpm"
    double poisson_ratio = 0.35;                  ///< [1] rkpm matrix nu (paper: not given)
    double node_spacing = 3.0;                    ///< [m] rkpm node spacing
    double support_factor = 2.0;                  ///< [1] rkpm support radius / node spacing
    std::int64_t quadrature_order = 2;            ///< Gauss points per direction per background cell
    std::int64_t cell_subdivision = 2;            ///< background cells per node spacing, per direction
    std::int64_t surface_points = 32;             ///< per sphere (even)
    double bond_penalty = 100.0;                  ///< [Pa/m] alpha
    double pin_penalty = 1.0;                     ///< [1] beta / (E h)
    double cg_tolerance = 1e-10;                  ///< [1]
    std::int64_t cg_max_iterations = 20000;
    std::string linear_solver = "cg_ic";         ///< rkpm: "cg_ic" | "cg" | "ldlt" | "auto" | "amg"
    std::int64_t cut_cell_depth = 2;             ///< rkpm: octree levels in cut quadrature cells
    double surface_spacing = 0.5;                ///< rkpm: surface point spacing / h
    std::string boundary = "free";               ///< rkpm: "free" | "clamped" | "rollers"
    double boundary_penalty = 100.0;             ///< rkpm: beta / (E / h) for clamped / rollers
    std::string boundary_faces = "all";          ///< rkpm: Gamma_u, "all" or comma-separated x_lo, ..., z_hi
    bool strain_statistics = false;              ///< rkpm: max principal strain of the matrix field (Fig. 4)
    std::vector<double> strain_histogram_edges;  ///< [1] bin edges of that strain at eps0 = opening_strain
    std::string strain_points = "matrix";        ///< rkpm: "matrix" | "box" | "nodes" (rkpm_matrix.hpp)
  };
  static ParamSpec<Params> spec();
  explicit PtcStrain(const Params& p);

  std::string name() const override { return "ptc_strain"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override;
  void bind(State& s) override;
  Clock clock() const override { return clock_; }
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override;
  std::vector<double> column_values(const State& s) const override;
  void visit(Archive& ar, const std::string& prefix) override;
  /// The solver's analysis and factorisation (its warm start, which visit() stores, stays).
  void release_caches() override { solver_.invalidate(); }
  std::vector<EdgeOutput> edge_outputs() const override {
    return held_edge_output(contacts_);
  }
  EdgeOutput* held_edges() override { return &contacts_; }

 private:
  Params p_;
  Clock clock_;
  double length_ = 0.0;
  LaplacianSolver solver_;
  std::vector<std::string> suffix_;   ///< per eps0
  std::vector<double> held_;          ///< the column values of the last evaluation (resistivity via length_)
  ptc::ThermalStrainLaw law_;         ///< eps0(T) (used when p_.temperatures is not empty)
  std::vector<std::string> tsuffix_;  ///< per temperature
  EdgeOutput contacts_;               ///< held per-contact results of the last evaluation
  std::vector<std::string> faces_;    ///< boundary_faces, parsed
  std::size_t histogram_columns() const { return p_.opening_histogram_edges.size() >= 2 ? p_.opening_histogram_edges.size() + 1 : 0; }
  std::size_t strain_columns() const {
    if (!p_.strain_statistics) return 0;
    return 5 + (p_.strain_histogram_edges.size() >= 2 ? 2 * (p_.strain_histogram_edges.size() + 1) : 0);
  }
  /// One unit solve of the chosen matrix model: the touching contacts with their unit openings;
  /// matrix size (springs or RKPM nodes), residual and the strain columns into the arguments.
  struct UnitResult;
  UnitResult unit_contacts(const State& s) const;
};

}  // namespace sparkdem::physics
