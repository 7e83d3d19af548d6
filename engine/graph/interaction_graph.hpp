#pragma once
/// The interaction graph: one view of who is connected to whom, and through what.
///
/// CONTRACT. Network modules (electrical, thermal, percolation, and any later network model)
/// build their matrices only through InteractionGraph + LaplacianSolver (engine/graph/
/// laplacian.hpp); none of them walks the contact table or the bond table on its own. A module
/// turns the per-edge geometry below into a conductance per edge, and hands the graph's (a, b)
/// lists and its conductances to the one Laplacian assembly.
///
/// Nodes: particles 0..n-1 (local indices, the order of the ParticleStore), then, when walls are
/// requested, one node per wall n..n+W-1 (in the order of State::walls).
///
/// Edges, each unordered pair at most once, in a deterministic order that does not depend on the
/// thread count:
///   1. contact-table rows, in table order:
///        - kind Neck    if the table has the neck column (GraphOptions::neck_column) and the
///                       row's neck radius is > 0, whatever its overlap (a sintered neck outlives
///                       zero and negative overlap); radius = the neck radius;
///        - kind Contact otherwise, if the overlap is > 0; radius = lens radius (below);
///        - no edge otherwise (a plain candidate at a gap; it may still become a Near edge);
///      rows of pairs that hold an intact bond are skipped when bonds are requested: the pair
///      appears once, as Bond (bond contact rule "add" keeps such pairs in both tables);
///   2. intact bonds, in bond-table order (kind Bond; radius = the bond table's neck column if
///      it has one, else 0); a second intact bond of the same pair is ignored;
///   3. near pairs (kind Near, radius 0): pairs that are not edges yet and whose surface gap
///      lies in [0, near_gap], found by a neighbour search on the current positions with skin
///      near_gap (NOT from the contact table, so near_gap may exceed the Verlet skin), in the
///      search's order (by first index);
///   4. walls (kind Wall), wall by wall, particles in index order: particles overlapping the wall
///      (radius sqrt(r^2 - d^2), the plane section), and, if wall_gap > 0, particles with a gap
///      in [0, wall_gap] (radius 0).
/// Particle-particle edges have a, b ordered by global id (id[a] < id[b], as in the tables);
/// wall edges have a = particle, b = wall node.
///
/// Geometry is recomputed from the CURRENT positions and radii, not taken from the per-row
/// overlap of the last force pass (which is stale after a drift, and absent for bonds and near
/// pairs). Only the classification Contact/Neck of a contact row uses the current overlap too.
///
/// Per-node data: node_radius()/node_radii() (walls: +infinity, i.e. a plane is a sphere of
/// infinite radius, consistent with R* = r_i for a wall contact), and node_field() for any
/// one-component particle quantity by name ("radius", "mass", or a declared field such as
/// "temperature"), with a given value on wall nodes. Anything else per node (positions,
/// materials, ...) a module reads from State by the particle index, which is the node index.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "engine/core/types.hpp"
#include "engine/state/state.hpp"

namespace sparkdem {

enum class EdgeKind : std::uint8_t { Contact, Neck, Bond, Near, Wall };

/// "contact", "neck", "bond", "near", "wall".
const char* edge_kind_name(EdgeKind k);

struct GraphOptions {
  bool contacts = true;                     ///< contact-table rows in contact (overlap > 0) or with a neck
  bool bonds = true;                        ///< intact bonds
  double near_gap = 0.0;                    ///< [m] also connect pairs with 0 <= gap <= near_gap (tunnelling, thermal gaps); 0 = off
  bool walls = false;                       ///< walls become extra nodes n..n+W-1
  double wall_gap = 0.0;                    ///< [m] also connect particles within this gap of a wall; 0 = overlap only
  std::string neck_column = "neck_radius";  ///< per-row state column holding a neck radius [m] ("" = none)
};

struct InteractionGraph {
  std::size_t particle_nodes = 0;  ///< n
  std::size_t wall_nodes = 0;      ///< W (0 unless GraphOptions::walls)
  std::vector<Index> a, b;         ///< edge end points (node indices)
  std::vector<EdgeKind> kind;
  std::vector<double> distance;          ///< [m] centre distance; particle-to-wall signed distance for wall edges
  std::vector<double> overlap;           ///< [m] r_a + r_b - d (r_a - d for a wall): > 0 overlap, < 0 gap
  std::vector<double> radius;            ///< [m] contact radius (neck, lens, plane section; 0 for gaps)
  std::vector<std::int64_t> source_row;  ///< row in the contact table (Contact, Neck) or bond table (Bond); -1 otherwise
  /// Hash of (particle_nodes, wall_nodes, a, b): equal while the topology is unchanged, so a
  /// module can keep per-edge caches. (LaplacianSolver checks its matrix structure itself.)
  std::uint64_t topology_hash = 0;

  std::size_t nodes() const { return particle_nodes + wall_nodes; }
  std::size_t size() const { return a.size(); }
  /// Node index of wall w (only when walls were requested).
  Index wall_node(std::size_t w) const { return static_cast<Index>(particle_nodes + w); }
  bool is_wall_node(Index v) const { return static_cast<std::size_t>(v) >= particle_nodes; }
  /// Number of edges of a kind.
  std::size_t count(EdgeKind k) const;
};

/// Build the graph of the state (cost: one pass over each table, plus one neighbour search when
/// near_gap > 0, plus N per wall). Throws SetupError on negative gaps or tables that refer to
/// particles that do not exist.
InteractionGraph build_interaction_graph(const State& s, const GraphOptions& opt = {});

/// O(N^2) reference with the same semantics, written pair by pair rather than table by table
/// (for the tests). Edge order differs; compare as sets.
InteractionGraph build_interaction_graph_brute_force(const State& s, const GraphOptions& opt = {});

/// Hash of the topology (node counts and the ordered (a, b) list).
std::uint64_t topology_hash(std::size_t particle_nodes, std::size_t wall_nodes, const std::vector<Index>& a, const std::vector<Index>& b);

/// Radius of the intersection circle of two spheres (the "lens radius") of radii ra, rb at centre
/// distance d. With x = (d^2 + ra^2 - rb^2) / (2 d) the distance from centre a to the radical
/// plane, a^2 = ra^2 - x^2, written without cancellation as
///     a^2 = h (d - ra + rb) (d + ra - rb) (d + ra + rb) / (4 d^2),   h = ra + rb - d,
/// (the two factors (ra - x) = h (d - ra + rb) / (2d) and (ra + x) = (d + ra - rb)(d + ra + rb) / (2d)).
/// Returns 0 when the spheres do not intersect in a circle (h <= 0, or one inside the other,
/// d <= |ra - rb|, the continuous limit) or d = 0.
inline double lens_radius(double ra, double rb, double d) {
  const double h = ra + rb - d;
  if (!(h > 0.0) || !(d > 0.0)) return 0.0;
  const double p = h * (d - ra + rb) * (d + ra - rb) * (d + ra + rb);
  return p > 0.0 ? std::sqrt(p) / (2.0 * d) : 0.0;
}

/// Radius of the section of a sphere of radius r by a plane at signed distance d from its centre:
/// sqrt(r^2 - d^2) for |d| < r, else 0. Used for every wall shape (exact for planes; for a
/// cylinder wall it is the tangent-plane approximation, good while r << cylinder radius).
inline double plane_section_radius(double r, double d) {
  const double q = (r - d) * (r + d);
  return q > 0.0 ? std::sqrt(q) : 0.0;
}

/// Radius of node v: the particle radius, +infinity for a wall node.
double node_radius(const State& s, const InteractionGraph& g, Index v);
/// node_radius for every node.
std::vector<double> node_radii(const State& s, const InteractionGraph& g);
/// A one-component particle quantity for every node: "radius", "mass", or a declared field of
/// the ParticleStore; wall nodes get `wall_value`. Throws SetupError for an unknown field or a
/// field with more than one component.
std::vector<double> node_field(const State& s, const InteractionGraph& g, const std::string& name,
                               double wall_value = std::numeric_limits<double>::quiet_NaN());

}  // namespace sparkdem
