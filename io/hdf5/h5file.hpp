#pragma once
/// Small RAII wrapper around the HDF5 C API (only what sparkdem needs).
///
/// Paths are '/'-separated ("/frames/000000/particles/position"); a path without a leading
/// '/' is relative to the root group. Parent groups are created as needed when writing.
/// Every failure throws sparkdem::SetupError naming the file, the object and what failed;
/// HDF5's own error printing is switched off.
///
/// Storage conventions:
///  - double  -> 64-bit IEEE little endian, int64 -> 64-bit signed little endian
///    (no conversion on x86, so values round-trip bit for bit);
///  - array datasets are 1-D (components == 0) or 2-D rows x components, row-major;
///  - scalars are datasets with a scalar dataspace;
///  - strings are fixed-length (exact byte size, NULLPAD) so any byte content round-trips;
///    the empty string is stored with a null dataspace.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace sparkdem::io {

/// An open HDF5 file. Move-only; the file is closed by the destructor (or by close()).
class H5File {
 public:
  /// Creates (truncates) a file for writing. `userblock` bytes (0, or a power of two >= 512)
  /// are reserved at the start of the file for the caller (HDF5 neither writes nor reads them).
  static H5File create(const std::filesystem::path& path, std::size_t userblock = 0);
  /// Opens an existing file read-only; `open_as`, when given, is the name HDF5 opens (e.g. the
  /// /proc/self/fd entry of a verified file) while `path` names the file in messages.
  static H5File open_read(const std::filesystem::path& path, const std::filesystem::path& open_as = {});
  /// Opens, read-only, a file image held in memory (the complete bytes of an HDF5 file, user
  /// block included) with HDF5's core driver; the file on disk is never touched. `path` only
  /// names the file in error messages. The bytes are not copied: HDF5 reads `image` itself, which
  /// must outlive the returned file (and stay unchanged).
  static H5File open_image(const std::filesystem::path& path, std::span<const unsigned char> image);

  H5File(H5File&& other) noexcept;
  H5File& operator=(H5File&& other) noexcept;
  H5File(const H5File&) = delete;
  H5File& operator=(const H5File&) = delete;
  ~H5File();

  /// Name of the file on disk.
  const std::filesystem::path& path() const { return path_; }
  bool is_open() const { return id_ >= 0; }
  /// Closes the file, flushing it; throws if HDF5 reports a failure. No-op when closed.
  void close();

  /// True if every component of the path exists (the root "/" always exists).
  bool exists(const std::string& path) const;
  /// Creates a group and its missing parents; no-op if the group exists.
  void create_group(const std::string& path);
  /// Names of the direct children of a group, in name order.
  std::vector<std::string> children(const std::string& group) const;
  /// Dimensions of a dataset (empty for scalars and the empty string).
  std::vector<std::size_t> shape(const std::string& dataset) const;

  /// Creates an external link at `path` (missing parent groups are created) to the object
  /// `target_object` of the file `target_file`. A relative `target_file` is resolved by HDF5
  /// relative to the directory of this file when the link is followed.
  void create_external_link(const std::string& path, const std::string& target_file, const std::string& target_object);

  /// Writes an array dataset: 1-D when components == 0, else rows x components with
  /// rows = data.size() / components. Zero rows are allowed. The dataset must not exist.
  void write(const std::string& path, std::span<const double> data, int components = 0);
  void write(const std::string& path, std::span<const std::int64_t> data, int components = 0);
  /// Writes a scalar dataset.
  void write_scalar(const std::string& path, double x);
  void write_scalar(const std::string& path, std::int64_t x);
  /// Writes a string dataset (any bytes, any length).
  void write_string(const std::string& path, const std::string& s);

  /// Reads a floating-point dataset of any rank, flattened row-major (see shape()).
  std::vector<double> read_doubles(const std::string& path) const;
  /// Reads an integer dataset of any rank, flattened row-major (see shape()).
  std::vector<std::int64_t> read_int64s(const std::string& path) const;
  /// Reads a dataset holding exactly one value.
  double read_double(const std::string& path) const;
  std::int64_t read_int64(const std::string& path) const;
  /// Reads a string dataset written by write_string().
  std::string read_string(const std::string& path) const;

  /// Sets (or replaces) a scalar attribute on an existing group or dataset.
  void set_attribute(const std::string& object, const std::string& name, double x);
  void set_attribute(const std::string& object, const std::string& name, std::int64_t x);
  void set_attribute(const std::string& object, const std::string& name, const std::string& s);
  bool has_attribute(const std::string& object, const std::string& name) const;
  double attribute_double(const std::string& object, const std::string& name) const;
  std::int64_t attribute_int64(const std::string& object, const std::string& name) const;
  std::string attribute_string(const std::string& object, const std::string& name) const;

 private:
  H5File(std::filesystem::path path, std::int64_t id) : path_(std::move(path)), id_(id) {}
  /// Throws unless the file is open.
  void require_open(const std::string& what) const;
  /// Throws a SetupError naming this file, with HDF5's innermost error message appended.
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path path_;
  std::int64_t id_ = -1;  ///< hid_t of the file (hid_t is int64_t since HDF5 1.10)
};

}  // namespace sparkdem::io
