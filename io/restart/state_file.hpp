#pragma once
/// Reading a state back from a checkpoint file (io/restart/checkpoint_file.hpp: verified before
/// HDF5 sees it): --restart, a stage's `from_snapshot`, sweep items and the loader's checks of a
/// snapshot's walls all read through here.
#include <cstdint>
#include <filesystem>
#include <utility>

#include "engine/state/state.hpp"
#include "io/restart/hdf5_archive.hpp"

namespace sparkdem::io {

/// Throws SetupError naming `file` when a particle's material index is not one of s.materials
/// (nothing to check while s.materials is empty: a checkpoint does not store the materials).
void check_materials(const State& s, const std::filesystem::path& file);

/// The state of an open checkpoint archive into `s`: its stage index and whether it was taken
/// inside that stage. Throws SetupError when a particle's material index is not one of s.materials
/// (when those are set: a checkpoint does not store the materials).
std::pair<std::int64_t, bool> read_state(Hdf5Archive& ar, State& s);

/// Read a checkpoint file into `s` (state only); returns its stage index and whether it was taken
/// inside that stage.
std::pair<std::int64_t, bool> read_checkpoint(const std::filesystem::path& file, State& s);

}  // namespace sparkdem::io
