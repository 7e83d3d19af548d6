#pragma once
/// HDF5 implementation of the checkpoint Archive.
///
/// Every item is a dataset at the path given by its name (relative to the file root):
/// arrays are 1-D (components == 1) or rows x components, scalars are scalar datasets and
/// strings are fixed-length byte-exact string datasets (see io/hdf5/h5file.hpp).
/// The file is a sealed checkpoint (io/restart/checkpoint_file.hpp): an HDF5 file with a 512-byte
/// user block holding a header with the payload length and an FNV-1a 64 checksum.
/// Writing goes to `path + ".tmp"`; commit() closes it, seals it (header, fsync) and renames it
/// to `path` (then fsyncs the directory), so a crash at any moment leaves either the previous
/// checkpoint or the new one under `path`, never a partial one; an uncommitted archive removes
/// its tmp file. Reading verifies the length and checksum with plain file I/O before any HDF5
/// call, then lets HDF5 read the verified file through its open descriptor (/proc/self/fd; a file
/// renamed over `path` meanwhile makes the open fail; where /proc is missing, from a copy of the
/// verified bytes in memory, which the reading archive holds): a truncated, corrupt or foreign file
/// gives a SetupError saying what is wrong, and never reaches the HDF5 library.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "io/hdf5/h5file.hpp"

namespace sparkdem::io {

class Hdf5Archive final : public sparkdem::Archive {
 public:
  /// Starts a checkpoint that becomes `path` on commit(); writes into `path + ".tmp"`.
  static Hdf5Archive for_writing(const std::filesystem::path& path);
  /// Opens an existing checkpoint for restoring, after verifying it (see above).
  static Hdf5Archive for_reading(const std::filesystem::path& path);

  Hdf5Archive(Hdf5Archive&& other) noexcept;
  Hdf5Archive& operator=(Hdf5Archive&&) = delete;
  Hdf5Archive(const Hdf5Archive&) = delete;
  Hdf5Archive& operator=(const Hdf5Archive&) = delete;
  /// Closes the file; an uncommitted checkpoint's tmp file is removed.
  ~Hdf5Archive() override;

  /// Writing mode: closes the file and atomically renames the tmp file to the final path.
  /// Nothing can be visited afterwards.
  void commit();
  /// Writing mode: closes the file and renames the tmp file to the final path, without sealing
  /// or syncing it: a scratch copy that no reader accepts (blank header) until seal_checkpoint()
  /// makes it a checkpoint. For the watchdog's copy of the last healthy state.
  void commit_unsealed();
  /// The final checkpoint path (not the tmp file).
  const std::filesystem::path& path() const { return path_; }

  bool reading() const override { return reading_; }
  bool has(const std::string& name) const override;
  using Archive::visit;
  void visit(const std::string& name, std::vector<double>& v, int components = 1) override;
  void visit(const std::string& name, std::vector<std::int64_t>& v, int components = 1) override;
  void visit(const std::string& name, double& x) override;
  void visit(const std::string& name, std::int64_t& x) override;
  void visit(const std::string& name, std::string& s) override;

 private:
  Hdf5Archive(H5File file, std::filesystem::path path, bool reading);
  /// Throws unless `name` can be visited now; in reading mode also unless it exists.
  void require_item(const std::string& name) const;
  /// Reading mode: throws unless the stored array has `components` values per row.
  void require_components(const std::string& name, int components) const;

  std::vector<unsigned char> image_;  ///< reading: the verified file HDF5 reads (declared before file_: outlives it)
  H5File file_;
  std::filesystem::path path_;  ///< final checkpoint path
  std::filesystem::path tmp_;   ///< file being written (writing mode)
  bool reading_;
  bool pending_ = false;  ///< writing and not committed yet: the tmp file is ours to remove
};

}  // namespace sparkdem::io
