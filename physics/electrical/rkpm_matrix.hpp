#pragma once
/// # rkpm_matrix — the paper's continuum thermoelastic matrix (meshless RKPM) for rigid fillers
///
/// Source: Barbieri et al., "Pyroresistive response of percolating conductive polymer
/// composites" (seed 002), §II.3 and SM S4, Eq. (S15)-(S24), rebuilt in
/// /work/shared/physics/cpc-and-networks.md §1.2; the RKPM itself follows the classic reproducing
/// kernel particle method (linear basis, corrected kernel). The bonded-network alternative is
/// ptc_matrix.hpp; both give the sphere displacements per unit eps0, hence every contact's unit
/// opening n_ij . (U_j - U_i).
///
/// PROBLEM (S15). The polymer occupies Omega = (box or ball) minus the spheres S_I (rigid,
/// non-expanding, translation U_I only, no rotation). Polymer: isotropic, E, nu (lambda, mu,
/// K = lambda + 2 mu / 3), thermal eigenstrain eps_TH = eps0 I. Weak form (per unit eps0):
///     int_Omega eps(du) : C eps(u) dV  +  alpha sum_I int_{dS_I} du.(u - U_I) dS
///       + beta (pins)                  =  int_Omega eps(du) : C I dV  = int_Omega 3K div(du) dV
///     alpha sum_I int_{dS_I} dU_I.(U_I - u) dS = 0.
/// The penalty 1/2 alpha int (u - U_I)^2 is a quadratic in (u - U_I): its Hessian has +alpha on
/// the diagonal blocks and -alpha on the matrix-sphere blocks (the printed S24 shows no sign;
/// the note §1.2 explains the minus). Interface law implied: sigma_rr = alpha (u_r - U_r) on dS_I
/// (matrix traction balances the penalty force; alpha -> inf is a perfect bond).
///
/// DISCRETISATION. u(x) = sum_i phi_i(x) d_i over grid nodes x_i (spacing h), with
///     phi_i(x) = p(0)^T M(x)^{-1} p(z_i) w(|z_i|),   z_i = (x - x_i)/rho,   rho = support_factor h,
///     p(z) = (1, z_x, z_y, z_z)^T,  M(x) = sum_i p(z_i) p(z_i)^T w(|z_i|)  (4x4, solved by LDLT),
///     w(xi) = 1 - 6 xi^2 + 8 xi^3 - 3 xi^4 (0 <= xi <= 1), 0 beyond  (quartic spline).
/// This reproduces every linear field exactly: sum_i phi_i = 1, sum_i phi_i x_i = x, and so
/// sum_i grad phi_i x_i^T = I (linear consistency, the basis of the patch test).
/// Gradients (b = M^{-1} p(0)):  phi_i = b^T p_i w_i,
///     d phi_i/dx_k = (db/dx_k)^T p_i w_i + b^T (dp_i/dx_k) w_i + b^T p_i dw_i/dx_k,
///     db/dx_k = -M^{-1} (dM/dx_k) b,   dp_i/dx_k = (0, e_k)/rho,
///     dw_i/dx_k = (-12 + 24 xi - 12 xi^2) z_k / rho  (= w'(xi)/xi * dxi/dx_k, regular at xi = 0).
/// Stiffness blocks (nodes i, j; components c, d; g = grad phi):
///     K_ij,cd = int_Omega [lambda g_i,c g_j,d + mu (delta_cd g_i.g_j + g_i,d g_j,c)] dV
/// Thermal load per unit eps0:  F_i,c = int_Omega 3K g_i,c dV.
/// Sphere coupling (scalar x I_3):  K_mm,ij += alpha int phi_i phi_j dS,
///     K_ms,iI = -alpha int phi_i dS,  K_ss,II = alpha |dS_I|  (= 4 pi R^2 unless clipped).
/// Unknowns: 3 per kept node, then 3 per sphere. The system is symmetric positive definite once
/// the translation is pinned (below); solved by Eigen ConjugateGradient (Jacobi preconditioner)
/// with an incomplete-Cholesky preconditioner (`solver` cg_ic, default) to a relative residual
/// cg_tolerance, or Jacobi CG (cg), or a sparse LDLT (ldlt; auto = LDLT up to direct_limit
/// unknowns, else cg_ic). Measured: the RKPM stiffness with the alpha = 100 E sphere penalty is
/// poorly conditioned (a 20 R box at phi = 25 %, h = 3 R, 2967 unknowns: 3902 Jacobi-CG
/// iterations, 15 s, against 97 IC-CG iterations, 2.9 s; a 35 R box, 14268 unknowns: 217 IC-CG
/// iterations) and has ~350-500 non-zeros per row, so LDLT fills in badly (5500 unknowns: LDLT
/// 2.6x slower than Jacobi CG). `solver` amg: hypre's BoomerAMG-PCG with the three displacement
/// components as separate functions (the "unknown" approach; Settings::num_functions = 3). Measured
/// (issue 39 item 3; 20 R box, phi = 25 %, h = 3 R, 3618 unknowns, to 1e-10): 713-794 PCG iterations
/// at strength thresholds 0.25-0.9 against 137 IC-CG iterations, 6x the IC-CG time. The alpha = 100 E
/// penalty couples each sphere's three unknowns to every node near its surface, far from the
/// M-matrix structure AMG's interpolation assumes; kept as an option, never a default. The relative residual
/// |K x - F| / |F| is reported.
///
/// ASSEMBLY (issue 39 item 3). The volume integrals are formed background cell by background
/// cell; the cells' dense local blocks (the shape functions and the block products: nearly all of
/// the assembly) are computed in batches on the OpenMP threads, then added to the global matrix in
/// cell order with each thread owning a range of rows, so every entry sums its contributions in one
/// order: the system and its solution are bit for bit the same on any number of threads. Per cell
/// the nodes near its bounding box are looked up once.
/// QUADRATURE (volume). Background cells of edge h / cell_subdivision tile the node grid;
/// quadrature_order^3 Gauss-Legendre points per cell. A cell wholly in the matrix keeps all its
/// points; a cell wholly inside a sphere or outside the domain none; a CUT cell (its circumscribed
/// ball crosses a sphere surface or the ball boundary) is split into eight, recursively, down to
/// cut_cell_depth levels; at the last level the cut sub-cells keep the Gauss points that lie in
/// the matrix, with their full weight (staircase). The volume error is thus O(cell / 2^depth)
/// per cut cell, and the gap between touching fillers is sampled down to h / (cell_subdivision
/// 2^depth) (`Result::quadrature_volume` is reported against the exact volume). The RKPM shape
/// functions are rational, so even uncut cells are integrated only approximately; the linear
/// patch test is nevertheless passed exactly at ANY quadrature, because the reproduced linear
/// field has the exact constant strain at every quadrature point (stress-free under eps_TH).
/// QUADRATURE (surface). Sphere I carries n_I = max(surface_points, 4 pi R_I^2 / (surface_spacing
/// h)^2) points (even): a Fibonacci spiral on the upper half (z_k = 1 - (2k+1)/n, azimuth k x
/// golden angle, k < n/2) and their antipodes, all with the equal weight 4 pi R^2 / n. The
/// antipodal pairing integrates every odd polynomial exactly (and keeps an inversion-symmetric
/// problem symmetric: the centred sphere stays at U = 0); even moments carry an O(1/n) error
/// (n = 32: the second moment of a unit sphere is 4 pi / 3 within 0.1 %). The spacing rule keeps
/// the penalty integral resolved as h shrinks below R (a fixed 32 points at h = 0.5 R would leave
/// nodal supports between surface points). Points outside the domain or inside another sphere
/// are dropped (no polymer there: the overlap of touching pairs, the part of a sphere sticking
/// out of the box).
/// NODES. Grid lo + h (i, j, k), h = edge / round(edge / node_spacing) (the box edges are node
/// planes; the ball uses its bounding cube). A node is kept only if its support holds at least
/// one volume quadrature point (a node deep inside a sphere would have an empty row). Node count
/// for a 70 R box at node_spacing = 3 R: 24^3 = 13 824 (paper: 12 000).
///
/// ESSENTIAL CONDITIONS (`boundary`; the paper writes a penalty beta on a part Gamma_u of the
/// boundary with data u-bar and gives neither). "free" (default; note §1.2 "free expansion with
/// rigid-body modes removed"; Fig. 7's inset, the effective phi falling by ~1.6 points at
/// eps0 ~ 3 %, needs a composite that expands): the load is self-equilibrated (sum_i F_i =
/// int 3K grad(sum phi_i) = 0; the moment vanishes likewise by linear consistency), so a
/// statically determinate pin adds no reaction and leaves the free-expansion solution unchanged.
/// Pin: beta |u(c)|^2 / 2 at the domain centre c (beta = pin_penalty E h): removes the three
/// translations. Without spheres the three rotations are also free and are pinned the 3-2-1
/// way: u_y and u_z at c + a e_x, u_z at c + a e_y (a = a quarter of the domain edge). With
/// spheres a rigid rotation of the whole is NOT a null mode (the spheres do not rotate, so it
/// strains the penalty layer): no rotation pin then (it would add reactions). Alternatives (box
/// only): "clamped" beta int_{Gamma_u} |u|^2 dS (u-bar = 0) and "rollers" beta int_{Gamma_u} (u.n)^2 dS
/// (no normal motion, free sliding), beta = boundary_penalty E / h, Gamma_u = the boundary_faces
/// (default all six; e.g. {"z_lo"}: a sample held on one face, free elsewhere).
///
/// STRAIN FIELD (Fig. 4 of the paper, "distribution of the maximum principal strain"): with
/// strain_statistics on, the max principal value of the total strain sym(grad u) and of the
/// mechanical strain sym(grad u) - eps0 I at every volume quadrature point, as volume-weighted
/// histograms over strain_edges (per unit eps0), with means and negative fractions. Which points
/// (`strain_points`, issue 39 item 1: the paper does not say what its Fig. 4 histograms): "matrix"
/// (the matrix volume quadrature, weighted: the polymer only), "box" (a regular lattice of cell
/// centres at spacing h / cell_subdivision over the whole domain, filler interiors included, where
/// the RKPM field extends through the rigid spheres; equal weights), or "nodes" (the kept RKPM
/// nodes, unweighted).
///
/// E and alpha: the displacements depend on alpha / E (and nu), not on E alone.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/core/types.hpp"

namespace sparkdem::physics::rkpm {

/// The six faces of a box domain, in the order of (axis, side): x_lo, x_hi, y_lo, y_hi, z_lo, z_hi.
inline const std::array<std::string, 6> kBoxFaces = {"x_lo", "x_hi", "y_lo", "y_hi", "z_lo", "z_hi"};

struct Params {
  double youngs_modulus = 1.0;   ///< E [Pa]
  double poisson_ratio = 0.35;   ///< nu [1] (the paper gives none; 0.35 default, never tuned)
  double node_spacing = 3.0;     ///< target h [m] (adjusted to fit the domain edge)
  double support_factor = 2.0;   ///< rho / h [1]
  int quadrature_order = 2;      ///< Gauss points per direction per background cell (1..6)
  int cell_subdivision = 2;      ///< background cells per node spacing, per direction (>= 1)
  int cut_cell_depth = 2;        ///< octree levels splitting cut background cells (0: staircase on the cells)
  int surface_points = 32;       ///< per sphere, even (>= 2): the minimum
  double surface_spacing = 0.5;  ///< surface point spacing / h [1] (more points than surface_points when h < R)
  double bond_penalty = 100.0;   ///< alpha [Pa/m] (paper: 100 E in its length unit)
  double pin_penalty = 1.0;      ///< beta / (E h) [1]
  double cg_tolerance = 1e-10;   ///< relative residual |K d - F| / |F| (CG stop; checked for LDLT too)
  int cg_max_iterations = 20000;
  std::string solver = "cg_ic";  ///< "cg_ic" (incomplete Cholesky) | "cg" (Jacobi) | "ldlt" | "amg" | "auto" (LDLT up to direct_limit unknowns, else cg_ic)
  std::size_t direct_limit = 3000;
  double amg_strong_threshold = 0.5;  ///< "amg": BoomerAMG strength threshold [1]
  std::string boundary = "free";    ///< "free" (pinned translation) | "clamped" | "rollers" (box faces)
  double boundary_penalty = 100.0;  ///< beta / (E / h) [1] for clamped / rollers
  std::vector<std::string> boundary_faces{kBoxFaces.begin(), kBoxFaces.end()};  ///< faces of clamped / rollers
  bool strain_statistics = false;                                               ///< evaluate the max principal strain at every volume point
  std::vector<double> strain_edges;  ///< histogram bin edges, per unit eps0 [1] (empty: means only)
  std::string strain_points = "matrix";  ///< "matrix" | "box" | "nodes": where the strain statistics sample
};

/// Max principal strain over the matrix volume (per unit eps0; volume-weighted).
struct StrainStatistics {
  bool evaluated = false;
  std::vector<double> total_histogram;       ///< m bins of strain_edges, then below, above [1]
  std::vector<double> mechanical_histogram;  ///< the same for sym(grad u) - I
  double total_mean = 0.0, mechanical_mean = 0.0;
  double total_negative_fraction = 0.0, mechanical_negative_fraction = 0.0;
  std::size_t points = 0;     ///< sample points evaluated
  std::size_t uncovered = 0;  ///< sample points with no node cover (skipped; "box" only)
  double seconds = 0.0;
};

/// The matrix domain before the spheres are removed: the box [lo, hi], or, if ball_radius > 0,
/// the ball of that radius about (lo + hi) / 2 (then [lo, hi] should be its bounding cube).
struct Domain {
  Vec3 lo = Vec3::Zero();
  Vec3 hi = Vec3::Ones();
  double ball_radius = 0.0;  ///< [m]
};

/// The RKPM approximation: regular node grid, kept nodes, support radius. Evaluates the shape
/// functions and their gradients at a point.
class Approximation {
 public:
  Approximation() = default;
  Approximation(const Vec3& lo, const std::array<int, 3>& cells, double h, double support_factor);
  /// Keep only the grid nodes flagged (size = grid node count); renumbers the kept nodes.
  void keep(const std::vector<char>& flag);
  std::size_t grid_nodes() const { return static_cast<std::size_t>(n_[0]) * n_[1] * n_[2]; }
  std::size_t nodes() const { return position_.size(); }
  const std::vector<Vec3>& positions() const { return position_; }
  double spacing() const { return h_; }
  double support() const { return rho_; }
  /// Grid indices (kept or not) of the nodes within `radius` of x.
  void grid_nodes_near(const Vec3& x, double radius, std::vector<std::int64_t>& out) const;
  Vec3 grid_position(std::int64_t g) const;
  /// Kept node id of a grid index, -1 if dropped.
  std::int64_t id(std::int64_t g) const { return id_[static_cast<std::size_t>(g)]; }
  /// Kept nodes within rho of x with phi (and gradients if grad != nullptr). Returns false if
  /// the moment matrix is singular (fewer than 4 non-coplanar nodes in reach).
  bool shape(const Vec3& x, std::vector<std::int64_t>& ids, std::vector<double>& phi, std::vector<Vec3>* grad) const;
  /// As shape, over `candidates` only (kept node ids in grid order, a superset of the nodes within
  /// rho of x): a caller evaluating many points of one region looks the nodes up once.
  bool shape_among(const Vec3& x, const std::vector<std::int64_t>& candidates, std::vector<std::int64_t>& ids, std::vector<double>& phi,
                   std::vector<Vec3>* grad) const;
  /// Kept node ids within `radius` of x, in grid order.
  void kept_nodes_near(const Vec3& x, double radius, std::vector<std::int64_t>& out) const;

 private:
  Vec3 lo_ = Vec3::Zero();
  std::array<int, 3> n_{0, 0, 0};  ///< nodes per direction
  double h_ = 1.0, rho_ = 2.0;
  std::vector<std::int64_t> id_;  ///< grid index -> kept node id or -1
  std::vector<Vec3> position_;    ///< kept nodes
};

struct Result {
  std::vector<Vec3> sphere_displacement;  ///< U_I per unit eps0 [m]
  std::vector<Vec3> node_coefficient;     ///< d_i per unit eps0 [m]
  Approximation approximation;
  std::size_t volume_points = 0;   ///< kept volume quadrature points
  std::size_t surface_points = 0;  ///< kept surface quadrature points (all spheres)
  double quadrature_volume = 0.0;  ///< sum of the kept volume weights [m^3]
  double residual = 0.0;           ///< |K x - F| / |F| of the solve [1]
  int iterations = 0;              ///< CG iterations
  std::size_t unknowns = 0;
  std::size_t nonzeros = 0;
  double assembly_seconds = 0.0, solve_seconds = 0.0;
  StrainStatistics strain;  ///< filled if Params::strain_statistics
  /// u(x) per unit eps0 [m] (the RKPM field; inside spheres it is the extension of the field)
  Vec3 displacement(const Vec3& x) const;
  /// grad u (row = component, column = derivative) per unit eps0 [1]; throws outside the node cover
  Eigen::Matrix3d displacement_gradient(const Vec3& x) const;
  /// Buffers of the shape functions, kept by a caller that evaluates many points.
  struct GradientScratch {
    std::vector<std::int64_t> ids;
    std::vector<double> phi;
    std::vector<Vec3> grad;
  };
  /// grad u at x into G; false (G untouched) where x has no node cover.
  bool displacement_gradient(const Vec3& x, Eigen::Matrix3d& G, GradientScratch& w) const;
};

/// One solve for eps0 = 1. Throws SetupError on bad parameters, a singular moment matrix, or a
/// CG solve that does not reach cg_tolerance.
Result solve_unit(const std::vector<Vec3>& centre, const std::vector<double>& radius, const Domain& domain, const Params& p);

/// "all" or a comma-separated list of kBoxFaces names -> the names; throws SetupError otherwise.
std::vector<std::string> parse_box_faces(const std::string& text);

/// The equal-weight antipodal Fibonacci point set on the unit sphere (n even): unit vectors.
std::vector<Vec3> sphere_points(int n);

/// Closed form used by the tests: a rigid non-expanding sphere of radius a at the centre of a
/// concentric matrix ball of radius b (traction-free), interface sigma_rr(a) = alpha u_r(a),
/// eigenstrain eps0 = 1: u_r = A r + B / r^2 with
///     sigma_rr = 3K (A - 1) - 4 mu B / r^3,  sigma_rr(b) = 0,  sigma_rr(a) = alpha (A a + B / a^2).
/// Returns {A, B}; b = inf gives A = 1, B = -alpha a^4 / (4 mu + alpha a).
std::array<double, 2> single_sphere_closed_form(double a, double b, double E, double nu, double alpha);

}  // namespace sparkdem::physics::rkpm
