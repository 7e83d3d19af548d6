#pragma once
/// A homogeneous affine map of the whole scene about a point, x -> o + S (x - o) with S =
/// diag(scale): the particles' positions and the walls (planes and cylinders) move with it, the
/// radii do not. A stage key (`affine`, io/scenario/stage_facets.cpp) as LAMMPS's
/// `change_box ... remap` / `displace_atoms ... scale`: issue 59's uniform references of a
/// compact (the packed state densified isotropically or uniaxially through the same network).
///   plane: its current surface point maps (the offset u is kept, the point moves); its normal
///          must lie along a coordinate axis (so that the image is a plane with the same normal);
///   cylinder: its axis must lie along a coordinate axis and the two scales across it must be
///          equal; the axis point maps and the current radius R = radius - u becomes s_perp R.
/// The neighbour state is invalidated (the next step rebuilds it); contact rows stay (their
/// overlaps are recomputed from the positions); bonds keep their reference lengths (a bonded
/// body mapped is strained by the map); particle fields (displacements, velocities) are not mapped. Throws SetupError on a wall it cannot map or a
/// scale that is not finite and > 0.
#include "engine/state/state.hpp"

namespace sparkdem {

void apply_affine_scale(State& s, const Vec3& origin, const Vec3& scale);

}  // namespace sparkdem
