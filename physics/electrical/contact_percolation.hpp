#pragma once
/// # contact_percolation — connectivity of a contact network (seed 002)
///
/// Source: Barbieri et al., "Pyroresistive response of percolating conductive polymer
/// composites", §II.4 and SM S3; /work/shared/physics/cpc-and-networks.md §1.3-1.4.
///
/// Contact graph: particles i, j touch when their surface gap r_ij - (R_i + R_j) is <=
/// `touch_gap_rel` x (R_i + R_j) (overlapping pairs included; the paper: in the final contact set
/// within 0.1 % of D, i.e. touch_gap_rel = 1e-3; relative, so a scene scaled in size keeps its
/// network; the absolute `touch_tolerance` [m] is refused). It is built by the shared
/// InteractionGraph (contacts plus near pairs up to the tolerance), the same graph the
/// electrical_network module's `touching` model conducts on: for equal fillers its
/// touch_tolerance_relative (of the mean radius) = 2 touch_gap_rel gives the same set.
/// Per evaluation the module reports
///   spanning                 1 if one cluster holds particles of both electrode sets, else 0
///   spanning_clusters        number of such clusters
///   largest_cluster_fraction size of the largest cluster / N
///   coordination             Z = 2 (touching pairs) / N
///   touching_pairs           number of touching pairs
///   resistance               R_eq [Ohm]: the electrical_network's solve (signal
///                            "signal/electrical_resistance"; the whole network in one system,
///                            all electrode particles of a face held at one potential: parallel
///                            spanning clusters combine as 1/R = sum 1/R_k, the physical choice);
///                            +inf without a spanning cluster; NaN without an electrical_network
///   resistivity              rho = R_eq L [Ohm m] (L = `length`, or the cpc_fillers box edge);
///                            with unit conductances and lengths in units of R this is the
///                            paper's dimensionless rho (units of R / unit_conductance)
///   conductivity             sigma = 1 / rho [S/m] (0 without a spanning cluster)
/// Option `cluster_resistances` (the paper's SM S3 aggregation, kept to reproduce its figures):
/// one unit-conductance solve (`unit_conductance` [S], electrodes at 1 V and 0 V) gives every
/// spanning cluster's own resistance R_k = 1 V / I_k (clusters are disconnected, so one system
/// solves them all); columns resistance_cluster_mean = (1/n) sum_k R_k (the paper's arithmetic
/// mean; physically wrong for parallel clusters, note §1.4), resistivity_cluster_mean = that x L,
/// and resistance_parallel = 1 / sum_k (1/R_k) (equals `resistance` of the electrical_network).
///
/// Clock: on an event (like electrical_network): the initial state of the stage, then when a
/// particle moved more than 0.05 x the smallest radius or a bond broke.
#include <span>
#include <string>
#include <vector>

#include "engine/graph/laplacian.hpp"
#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem::physics {

namespace percolation {

struct Metrics {
  bool spanning = false;
  std::size_t spanning_clusters = 0;
  double largest_cluster_fraction = 0.0;  ///< [1]
  double coordination = 0.0;              ///< [1] 2 E / N
  std::size_t touching_pairs = 0;         ///< E (distinct pairs, a != b)
};
/// Connectivity of n nodes joined by the edges (a[e], b[e]) (self-loops and repeated pairs are
/// counted once), with electrode node sets high and low (a node in both counts for both).
Metrics metrics(std::size_t n, std::span<const Index> a, std::span<const Index> b, std::span<const Index> high, std::span<const Index> low);

/// Resistance [Ohm] of every spanning cluster (in order of their smallest node) of the network
/// of edges (a[e], b[e]) with conductance g_unit [S] each, `high` at 1 V and `low` at 0 V:
/// R_k = 1 V / I_k, I_k the current leaving the high nodes of cluster k. One sparse solve.
std::vector<double> cluster_resistances(std::size_t n, std::span<const Index> a, std::span<const Index> b, double g_unit,
                                        std::span<const Index> high, std::span<const Index> low, LaplacianSolver& solver);

/// Default clock of the filler-network modules (contact_percolation, ptc_strain): on an event,
/// when a particle moved more than 0.05 smallest radii or a bond broke (and on the initial state).
Clock geometry_event_clock(const State& s);
/// L [m] of rho = R_eq L: `given` if > 0, else the box edge recorded by a cpc_fillers stage
/// (SetupError naming `module` when there is none).
double box_length(const State& s, double given, const std::string& module);

}  // namespace percolation

class ContactPercolation final : public Module {
 public:
  struct Params {
    std::string high = "x_lo";
    std::string low = "x_hi";
    double touch_gap_rel = 0.0;  ///< [1] of R_i + R_j
    double length = 0.0;           ///< [m] 0: State::marks["cpc_fillers/box_length"]
    bool cluster_resistances = false;
    double unit_conductance = 1.0;  ///< [S] (cluster_resistances)
  };
  static ParamSpec<Params> spec();
  explicit ContactPercolation(const Params& p) : p_(p) {}

  std::string name() const override { return "contact_percolation"; }
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

 private:
  Params p_;
  Clock clock_;
  double length_ = 0.0;  ///< [m] L of rho = R L
  LaplacianSolver solver_;
  /// Held results of the last evaluation: spanning, spanning_clusters, largest_cluster_fraction,
  /// coordination, touching_pairs, resistance_cluster_mean, resistance_parallel.
  std::vector<double> held_ = std::vector<double>(7, 0.0);
};

}  // namespace sparkdem::physics
