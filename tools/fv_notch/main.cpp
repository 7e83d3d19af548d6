/// fv_notch: finite-volume reference of seed 001's notched rod (physics note §7.4), printed as
/// JSON. The solver is tests/support/fv_notched_bar.hpp (its comment block has the equations and
/// the method); this front end runs it on three grids h, h/2, h/4 (h = 25 um / m for the given
/// refinements m) and extrapolates R_eq and the notch temperatures (Richardson, observed order).
///
///   fv_notch                                     # defaults: r_mean 59 um, planes at r_mean from the ends
///   fv_notch --z-lo 6.1e-5 --z-hi 6.94e-3 --slab-half-width 1.18e-4 --grids 2,4,8
///   fv_notch --unnotched                         # plain bar (closed-form check)
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <iostream>
#include <optional>
#include <vector>

#include "support/fv_notched_bar.hpp"

namespace {
using nlohmann::json;
using namespace sparkdem;

json to_json(const fv::Result& r) {
  return {{"h_m", r.h},
          {"nx", r.nx},
          {"nz", r.nz},
          {"solid_cells", r.solid_cells},
          {"potential_unknowns", r.potential_unknowns},
          {"steps", r.steps},
          {"dt_s", r.dt},
          {"R_eq_ohm", r.resistance},
          {"current_A", r.current},
          {"current_high_A", r.current_high},
          {"power_joule_W", r.power_joule},
          {"power_VI_W", r.power_vi},
          {"T_slab_mean_K", r.T_slab_mean},
          {"slab_volume_m3", r.slab_volume},
          {"T_max_K", r.T_max},
          {"T_notch_centre_K", r.T_notch_centre},
          {"T_mean_K", r.T_mean},
          {"heat_stored_J", r.heat_stored},
          {"heat_input_J", r.heat_input},
          {"energy_balance_rel", (r.heat_stored - r.heat_input) / r.heat_input},
          {"solid_volume_m3", r.solid_volume},
          {"wall_s", r.seconds}};
}

json rich(double f1, double f2, double f3) {
  const fv::Richardson r = fv::richardson(f1, f2, f3);
  return {{"values", {f1, f2, f3}},
          {"observed_order", std::isfinite(r.observed_order) ? json(r.observed_order) : json(nullptr)},
          {"extrapolated", r.extrapolated},
          {"error_band", r.band}};
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Finite-volume reference of the notched rod (R_eq, Joule heating): JSON on stdout"};
  fv::NotchedBar g;
  fv::Material m;
  fv::Loading ld;
  fv::Numerics num;
  double r_mean = 59e-6;
  std::optional<double> z_lo, z_hi, slab;
  std::vector<int> grids{2, 4, 8};
  bool unnotched = false, no_sym = false, time_check = false;
  app.add_option("--r-mean", r_mean, "DEM mean radius [m]: default planes at r_mean from the ends, slab half-width 2 r_mean");
  app.add_option("--z-lo", z_lo, "plane held at 0 V [m] (default r_mean)");
  app.add_option("--z-hi", z_hi, "plane held at the voltage [m] (default lz - r_mean)");
  app.add_option("--slab-half-width", slab, "notch slab |z - 3.5 mm| <= this [m] (default 2 r_mean)");
  app.add_option("--voltage", ld.voltage, "[V]");
  app.add_option("--t-end", ld.t_end, "heating time [s]");
  app.add_option("--steps", num.steps, "time steps (Crank-Nicolson, Rannacher start)");
  app.add_option("--grids", grids, "three refinements m, each h = 25 um / m, each twice the previous")->delimiter(',');
  app.add_flag("--unnotched", unnotched, "plain bar (no slots)");
  app.add_flag("--no-symmetry", no_sym, "solve the full width instead of the half x <= lx/2");
  app.add_flag("--time-check", time_check, "repeat the finest grid with twice the steps");
  CLI11_PARSE(app, argc, argv);
  ld.z_lo = z_lo.value_or(r_mean);
  ld.z_hi = z_hi.value_or(g.lz - r_mean);
  ld.slab_half_width = slab.value_or(2.0 * r_mean);
  g.notched = !unnotched;
  num.use_x_symmetry = !no_sym;
  if (grids.size() != 3) {
    std::cerr << "fv_notch: --grids needs three refinements\n";
    return 2;
  }
  json out;
  out["geometry"] = {{"lx_m", g.lx},
                     {"depth_m", g.depth},
                     {"lz_m", g.lz},
                     {"notched", g.notched},
                     {"notch_depth_m", g.notch_depth},
                     {"notch_z_m", {g.notch_z_lo, g.notch_z_hi}},
                     {"ligament_area_m2", (g.lx - 2 * g.notch_depth) * g.depth},
                     {"solid_volume_m3", g.solid_volume()}};
  out["material"] = {
      {"density", m.density}, {"heat_capacity", m.heat_capacity}, {"conductivity", m.conductivity}, {"resistivity", m.resistivity}};
  out["loading"] = {{"z_lo_m", ld.z_lo},   {"z_hi_m", ld.z_hi}, {"voltage_V", ld.voltage},
                    {"t_end_s", ld.t_end}, {"T0_K", ld.T0},     {"slab_half_width_m", ld.slab_half_width},
                    {"r_mean_m", r_mean}};
  std::vector<fv::Result> rs;
  try {
    for (int mm : grids) {
      num.h = 25e-6 / mm;
      rs.push_back(fv::solve(g, m, ld, num));
      out["grids"].push_back(to_json(rs.back()));
    }
    if (time_check) {
      num.steps *= 2;
      out["time_check"] = to_json(fv::solve(g, m, ld, num));
    }
  } catch (const std::exception& e) {
    std::cerr << "fv_notch: " << e.what() << "\n";
    return 2;
  }
  out["richardson"]["R_eq_ohm"] = rich(rs[0].resistance, rs[1].resistance, rs[2].resistance);
  out["richardson"]["T_slab_mean_K"] = rich(rs[0].T_slab_mean, rs[1].T_slab_mean, rs[2].T_slab_mean);
  out["richardson"]["T_notch_centre_K"] = rich(rs[0].T_notch_centre, rs[1].T_notch_centre, rs[2].T_notch_centre);
  out["richardson"]["T_max_K"] = rich(rs[0].T_max, rs[1].T_max, rs[2].T_max);
  out["R_eq_ohm"] = out["richardson"]["R_eq_ohm"]["extrapolated"];
  out["T_slab_mean_K"] = out["richardson"]["T_slab_mean_K"]["extrapolated"];
  out["T_max_K"] = rs[2].T_max;
  out["power_W"] = rs[2].power_joule;
  std::cout << out.dump(2) << "\n";
  return 0;
}
