#pragma once
/// Finite-volume reference of seed 001's notched rod (seed §3.3, second case; physics note §7.4):
/// Joule heating of a notched rectangular bar between two equipotential planes, adiabatic.
/// Written as the reference of the DEM validation; independent of the engine (Eigen and the
/// standard library only).
///
/// Geometry (SI, defaults = the validation case; NotchedBar):
///   bar x in [0, lx], y in [0, depth], z in [0, lz]: lx = depth = 1.0 mm, lz = 7.0 mm;
///   two rectangular slots cut from the faces x = 0 and x = lx, each notch_depth = 0.225 mm deep
///   in x and spanning z in [notch_z_lo, notch_z_hi] = [3.25, 3.75] mm, through the whole depth y.
///   Ligament 0.55 mm x 1.0 mm = 0.55 mm^2; solid volume 7.0 - 2 x 0.225 x 0.5 x 1.0 = 6.775 mm^3.
///   The slots go through y and the electrodes are planes z = const, so nothing depends on y: the
///   problem is solved in the x-z plane with every cell 1 depth deep (exact, not an approximation),
///   and, since both slots have the same depth, on the half x <= lx / 2 (mirror plane x = lx / 2
///   carries no normal current and no heat flux; `use_x_symmetry`, exact as well).
///
/// Equations (constant properties, eta = 1: all electrical power becomes heat):
///   div(sigma grad phi) = 0 between the planes z_lo < z < z_hi, sigma = 1 / rho_e;
///   phi = 0 on z = z_lo, phi = V on z = z_hi; zero normal current on every free surface;
///   the material beyond the planes (z < z_lo, z > z_hi) is equipotential and carries no current;
///   rho c dT/dt = div(lambda grad T) + q,   q = sigma |grad phi|^2 between the planes, 0 beyond;
///   zero heat flux on every surface (adiabatic), T(0) = T0 uniform. The potential is solved once.
///
/// Method: cell-centred finite volumes on a uniform square grid of side h that resolves the slots
/// exactly (h must divide lx / 2, lz, notch_depth, notch_z_lo and notch_z_hi; h = 25 um / m for
/// the validation geometry), 5-point stencil in x-z (the 7-point stencil with no y coupling).
///  * Potential: unknowns are the solid cells whose centre lies strictly between the planes;
///    cells with their centre on or beyond a plane hold the plane's potential. Conductance of a
///    face between two unknowns G = sigma A / h (A = h depth; harmonic mean of equal sigmas).
///    A face between an unknown cell (centre z_c) and a cell beyond plane z_p couples the unknown
///    to the plane itself at its true position: G = sigma A / |z_c - z_p| (0 < |z_c - z_p| <= h),
///    so a plane anywhere is represented exactly (for the unnotched bar the discrete solution is
///    the exact linear potential and R = rho_e (z_hi - z_lo) / (lx depth) to round-off).
///    SPD system, Eigen SimplicialLDLT (direct: no iteration tolerance).
///  * Current I = sum of G (phi_c - 0) over the faces of the plane z_lo (checked against the
///    current into z_hi); R_eq = V / I.
///  * Joule power per face P_f = G (dphi)^2 over the segment joining the two centres (or the
///    centre and the plane), deposited in the cells in proportion to the length of that segment
///    inside each cell (half and half for two cells; for a plane face the part of the segment
///    beyond the face belongs to the neighbour). The discrete identity
///    sum_f G (dphi)^2 = V I holds for the solved potential, so the total Joule power is V I to
///    round-off.
///  * Heat: every solid cell (beyond the planes too) stores and conducts heat; face conductance
///    lambda A / h, no flux through free surfaces. Crank-Nicolson with Rannacher start-up (the
///    first two steps replaced by four backward-Euler half steps, which damps the stiff modes
///    excited by the discontinuous source at the slot corners), direct LDLT factorisations. The
///    columns of the conduction matrix sum to zero, so heat stored = sum of sources x t_end
///    = V I t_end to round-off (checked in the tests to 1e-9).
///  * Grid convergence: richardson() on three grids h, h/2, h/4 with the observed order (the
///    re-entrant slot corners make the order below 2: the potential goes as r^(2/3) there).
/// References: Patankar, Numerical Heat Transfer and Fluid Flow (1980), ch. 4 (cell-centred FV,
/// harmonic face conductances); Rannacher, Numer. Math. 43 (1984) 309 (start-up of CN);
/// Roache, J. Fluids Eng. 116 (1994) 405 (Richardson extrapolation with observed order).

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sparkdem::fv {

/// Geometry [m]. notched = false gives the plain bar (the closed-form checks).
struct NotchedBar {
  double lx = 1.0e-3;     ///< width in x [m]
  double depth = 1.0e-3;  ///< thickness in y [m] (the 2-D cells are this deep)
  double lz = 7.0e-3;     ///< length along z [m]
  bool notched = true;
  double notch_depth = 0.225e-3;  ///< depth of each slot in x [m]
  double notch_z_lo = 3.25e-3;    ///< slot extent in z [m]
  double notch_z_hi = 3.75e-3;
  double solid_volume() const { return lx * depth * lz - (notched ? 2.0 * notch_depth * (notch_z_hi - notch_z_lo) * depth : 0.0); }
  double notch_z_mid() const { return 0.5 * (notch_z_lo + notch_z_hi); }
};

/// 304L, as in the seed.
struct Material {
  double density = 7900.0;       ///< rho [kg/m^3]
  double heat_capacity = 500.0;  ///< c [J/(kg K)]
  double conductivity = 15.0;    ///< lambda [W/(m K)]
  double resistivity = 0.73e-6;  ///< rho_e [Ohm m]
};

struct Loading {
  double z_lo = 59e-6;              ///< plane held at 0 V [m]
  double z_hi = 7.0e-3 - 59e-6;     ///< plane held at `voltage` [m]
  double voltage = 1.0;             ///< [V]
  double t_end = 10e-3;             ///< heating time [s]
  double T0 = 293.15;               ///< initial temperature [K]
  double slab_half_width = 118e-6;  ///< notch slab |z - z_mid| <= this [m] (seed: 4 r_mean thick)
};

struct Numerics {
  double h = 12.5e-6;          ///< cell size [m]
  int steps = 200;             ///< time steps (>= 2)
  bool use_x_symmetry = true;  ///< solve x <= lx/2 with a mirror plane (notched bar is symmetric)
  bool keep_fields = false;    ///< return phi and T per cell
};

struct Result {
  // grid
  int nx = 0, nz = 0;  ///< cells of the solved domain (nx of the half when symmetric)
  double h = 0.0;      ///< [m]
  std::size_t solid_cells = 0, potential_unknowns = 0;
  int steps = 0;
  double dt = 0.0;  ///< [s]
  // electrical
  double current = 0.0;       ///< I through z_lo [A]
  double current_high = 0.0;  ///< I through z_hi [A] (equals `current` to round-off)
  double resistance = 0.0;    ///< R_eq = V / I [Ohm]
  double power_vi = 0.0;      ///< V I [W]
  double power_joule = 0.0;   ///< sum of the cell sources [W]
  // thermal at t_end
  double T_slab_mean = 0.0;     ///< volume-weighted mean over the slab |z - z_mid| <= slab_half_width [K]
  double slab_volume = 0.0;     ///< solid volume of that slab [m^3]
  double T_max = 0.0;           ///< [K]
  double T_notch_centre = 0.0;  ///< at (lx/2, z_mid): mean of the cells touching that point [K]
  double T_mean = 0.0;          ///< over the whole solid [K]
  double heat_stored = 0.0;     ///< sum rho c V_cell (T - T0) [J]
  double heat_input = 0.0;      ///< power_joule t_end [J]
  double solid_volume = 0.0;    ///< [m^3] (whole bar)
  double seconds = 0.0;         ///< wall time of the solve
  // fields (keep_fields): cell (i, k) at index i + nx k; NaN for void cells
  std::vector<double> phi, T;
};

namespace detail {
inline bool divides(double len, double h) {
  const double q = len / h;
  return std::abs(q - std::round(q)) < 1e-6;
}
}  // namespace detail

/// Compiled once in fv_notched_bar.cpp (library sparkdem_reference, tools/CMakeLists.txt).
/// Solve the problem; throws std::invalid_argument for a grid that does not resolve the geometry
/// or planes outside the bar.
Result solve(const NotchedBar& g, const Material& m, const Loading& ld, const Numerics& num);

/// Richardson extrapolation from three grids h, h/2, h/4 (values f1, f2, f3): observed order
/// p = log2((f1 - f2) / (f2 - f3)) and f_inf = f3 + (f3 - f2) / (2^p - 1); `band` = |f_inf - f3|
/// (the grid error estimate of the finest value). Order NaN (and f_inf = f3, band = |f2 - f3|)
/// when the differences change sign (non-monotone convergence).
struct Richardson {
  double observed_order = 0.0;
  double extrapolated = 0.0;
  double band = 0.0;
};
inline Richardson richardson(double f1, double f2, double f3) {
  Richardson r;
  const double d12 = f1 - f2, d23 = f2 - f3;
  if (d12 != 0.0 && d23 != 0.0 && d12 / d23 > 1.0) {
    r.observed_order = std::log2(d12 / d23);
    r.extrapolated = f3 - d23 / (std::pow(2.0, r.observed_order) - 1.0);
    r.band = std::abs(r.extrapolated - f3);
  } else {
    r.observed_order = std::numeric_limits<double>::quiet_NaN();
    r.extrapolated = f3;
    r.band = std::abs(d23);
  }
  return r;
}

/// The closed forms of the unnotched bar (notched = false) used by the tests:
///   R = rho_e (z_hi - z_lo) / (lx depth);
///   far from the planes the heated bar rises uniformly, dT = V^2 t / (R rho c V_heated) with
///   V_heated = lx depth (z_hi - z_lo) (= q t / (rho c), q = V^2 / (R V_heated));
///   near an end, 1-D conduction into the unheated end piece of length a (= z_lo) with the
///   adiabatic face at z = 0 (image source): at the face z = 0
///     dT(0, t) = (q t / (rho c)) 4 i2erfc(a / (2 sqrt(D t))),  D = lambda / (rho c),
///   i2erfc(u) = ((1 + 2u^2) erfc(u) - 2u exp(-u^2) / sqrt(pi)) / 4 (Carslaw & Jaeger, 1959,
///   §2.2 and App. II), valid while the heated length is much longer than sqrt(D t).
inline double i2erfc(double u) {
  constexpr double kSqrtPi = 1.7724538509055160273;
  return 0.25 * ((1.0 + 2.0 * u * u) * std::erfc(u) - 2.0 * u * std::exp(-u * u) / kSqrtPi);
}

}  // namespace sparkdem::fv
