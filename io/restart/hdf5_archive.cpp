#include "io/restart/hdf5_archive.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>
#include <utility>

#include "engine/core/error.hpp"
#include "io/files/durable_file.hpp"
#include "io/restart/checkpoint_file.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

std::string shape_text(const std::vector<std::size_t>& dims) {
  std::string s = "(";
  for (std::size_t k = 0; k < dims.size(); ++k) s += (k ? ", " : "") + std::to_string(dims[k]);
  return s + ")";
}

}  // namespace

Hdf5Archive::Hdf5Archive(H5File file, fs::path path, bool reading)
    : file_(std::move(file)), path_(std::move(path)), tmp_(reading ? fs::path() : tmp_name(path_)), reading_(reading), pending_(!reading) {}

Hdf5Archive Hdf5Archive::for_writing(const fs::path& path) {
  return Hdf5Archive(H5File::create(tmp_name(path), kCheckpointHeaderBytes), path, false);
}

Hdf5Archive Hdf5Archive::for_reading(const fs::path& path) {
  std::error_code ec;
  if (fs::is_directory("/proc/self/fd", ec)) {
    const VerifiedCheckpoint verified(path);
    return Hdf5Archive(H5File::open_read(path, verified.same_file_path()), path, true);
  }
  std::vector<unsigned char> image = read_verified_checkpoint(path);
  H5File file = H5File::open_image(path, image);
  Hdf5Archive ar(std::move(file), path, true);
  ar.image_ = std::move(image);  // the vector's buffer, which the file reads, moves with it
  return ar;
}

Hdf5Archive::Hdf5Archive(Hdf5Archive&& other) noexcept
    : Archive(),
      image_(std::move(other.image_)),
      file_(std::move(other.file_)),
      path_(std::move(other.path_)),
      tmp_(std::move(other.tmp_)),
      reading_(other.reading_),
      pending_(std::exchange(other.pending_, false)) {}

Hdf5Archive::~Hdf5Archive() {
  if (!pending_) return;
  try {
    file_.close();
  } catch (const SetupError&) {
    // The checkpoint is being discarded anyway.
  }
  std::error_code ec;
  fs::remove(tmp_, ec);
}

void Hdf5Archive::commit() {
  if (reading_) throw SetupError("checkpoint '" + path_.string() + "': commit() on an archive opened for reading");
  if (!pending_) throw SetupError("checkpoint '" + path_.string() + "': already committed");
  file_.close();
  seal_checkpoint(tmp_);
  rename_durably(tmp_, path_);
  pending_ = false;
}

void Hdf5Archive::commit_unsealed() {
  if (reading_) throw SetupError("checkpoint '" + path_.string() + "': commit_unsealed() on an archive opened for reading");
  if (!pending_) throw SetupError("checkpoint '" + path_.string() + "': already committed");
  file_.close();
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0)
    throw SetupError("cannot rename '" + tmp_.string() + "' to '" + path_.string() + "': " + std::strerror(errno));
  pending_ = false;
}

bool Hdf5Archive::has(const std::string& name) const { return !name.empty() && file_.is_open() && file_.exists(name); }

void Hdf5Archive::require_item(const std::string& name) const {
  if (name.empty()) throw SetupError("checkpoint '" + path_.string() + "': empty item name");
  if (!file_.is_open()) throw SetupError("checkpoint '" + path_.string() + "': cannot visit item '" + name + "': already committed");
  if (reading_ && !file_.exists(name)) throw SetupError("checkpoint '" + path_.string() + "' has no item '" + name + "'");
}

void Hdf5Archive::require_components(const std::string& name, int components) const {
  const std::vector<std::size_t> dims = file_.shape(name);
  const bool ok = (components == 1 && dims.size() == 1) || (dims.size() == 2 && dims[1] == static_cast<std::size_t>(components));
  if (!ok)
    throw SetupError("checkpoint '" + path_.string() + "': item '" + name + "' has shape " + shape_text(dims) + ", expected (rows, " +
                     std::to_string(components) + ")");
}

void Hdf5Archive::visit(const std::string& name, std::vector<double>& v, int components) {
  require_item(name);
  if (components < 1) throw SetupError("checkpoint '" + path_.string() + "': item '" + name + "': components must be at least 1");
  if (reading_) {
    require_components(name, components);
    v = file_.read_doubles(name);
  } else {
    file_.write(name, v, components == 1 ? 0 : components);
  }
}

void Hdf5Archive::visit(const std::string& name, std::vector<std::int64_t>& v, int components) {
  require_item(name);
  if (components < 1) throw SetupError("checkpoint '" + path_.string() + "': item '" + name + "': components must be at least 1");
  if (reading_) {
    require_components(name, components);
    v = file_.read_int64s(name);
  } else {
    file_.write(name, v, components == 1 ? 0 : components);
  }
}

void Hdf5Archive::visit(const std::string& name, double& x) {
  require_item(name);
  if (reading_)
    x = file_.read_double(name);
  else
    file_.write_scalar(name, x);
}

void Hdf5Archive::visit(const std::string& name, std::int64_t& x) {
  require_item(name);
  if (reading_)
    x = file_.read_int64(name);
  else
    file_.write_scalar(name, x);
}

void Hdf5Archive::visit(const std::string& name, std::string& s) {
  require_item(name);
  if (reading_)
    s = file_.read_string(name);
  else
    file_.write_string(name, s);
}

}  // namespace sparkdem::io
