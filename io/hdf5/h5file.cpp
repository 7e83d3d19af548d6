#include "io/hdf5/h5file.hpp"

#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

#include "engine/core/error.hpp"

namespace sparkdem::io {
namespace {

static_assert(std::is_same_v<hid_t, std::int64_t>, "H5File stores hid_t as std::int64_t (HDF5 >= 1.10)");

namespace fs = std::filesystem;

/// Owns one HDF5 identifier and releases it with the matching H5?close function.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  Handle(Handle&& other) noexcept : id_(std::exchange(other.id_, H5I_INVALID_HID)), close_(other.close_) {}
  Handle& operator=(Handle&&) = delete;
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }

 private:
  hid_t id_;
  Closer close_;
};

/// Reading and writing functions of one kind of HDF5 object (dataset or attribute).
struct ObjectIo {
  hid_t (*get_type)(hid_t);
  hid_t (*get_space)(hid_t);
  herr_t (*read)(hid_t object, hid_t mem_type, void* buffer);
  herr_t (*write)(hid_t object, hid_t mem_type, const void* buffer);
};

const ObjectIo dataset_io{H5Dget_type, H5Dget_space,
                          [](hid_t d, hid_t t, void* b) { return H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, b); },
                          [](hid_t d, hid_t t, const void* b) { return H5Dwrite(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, b); }};

const ObjectIo attribute_io{H5Aget_type, H5Aget_space, [](hid_t a, hid_t t, void* b) { return H5Aread(a, t, b); },
                            [](hid_t a, hid_t t, const void* b) { return H5Awrite(a, t, b); }};

/// The most specific message of the current HDF5 error stack (then clears the stack).
std::string innermost_hdf5_error() {
  std::string message;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned, const H5E_error2_t* e, void* data) -> herr_t {
        if (e->desc != nullptr && e->desc[0] != '\0') *static_cast<std::string*>(data) = e->desc;
        return 0;
      },
      &message);
  H5Eclear2(H5E_DEFAULT);
  return message;
}

[[noreturn]] void throw_error(const fs::path& file, const std::string& what) {
  std::string message = "HDF5 file '" + file.string() + "': " + what;
  const std::string detail = innermost_hdf5_error();
  if (!detail.empty()) message += " (HDF5: " + detail + ")";
  throw SetupError(message);
}

void check(herr_t status, const fs::path& file, const std::string& what) {
  if (status < 0) throw_error(file, what);
}

Handle own(hid_t id, Handle::Closer close, const fs::path& file, const std::string& what) {
  if (id < 0) throw_error(file, what);
  return Handle(id, close);
}

/// "/a/b" for "a/b" and "/a/b".
std::string absolute(const std::string& path) { return !path.empty() && path[0] == '/' ? path : "/" + path; }

std::string dataset_label(const std::string& path) { return "dataset '" + absolute(path) + "'"; }

std::string attribute_label(const std::string& object, const std::string& name) {
  return "attribute '" + name + "' of '" + absolute(object) + "'";
}

/// Fixed-length string type of exactly `size` bytes (at least 1), padded with NULs.
Handle string_type(std::size_t size, const fs::path& file) {
  Handle type = own(H5Tcopy(H5T_C_S1), H5Tclose, file, "cannot create a string type");
  check(H5Tset_size(type.get(), std::max<std::size_t>(size, 1)), file, "cannot size a string type");
  check(H5Tset_strpad(type.get(), H5T_STR_NULLPAD), file, "cannot set string padding");
  check(H5Tset_cset(type.get(), H5T_CSET_UTF8), file, "cannot set string character set");
  return type;
}

/// Scalar dataspace for a non-empty string, null dataspace for the empty string.
Handle string_space(const std::string& s, const fs::path& file) {
  return own(H5Screate(s.empty() ? H5S_NULL : H5S_SCALAR), H5Sclose, file, "cannot create a dataspace");
}

Handle scalar_space(const fs::path& file) { return own(H5Screate(H5S_SCALAR), H5Sclose, file, "cannot create a dataspace"); }

/// Before allocating for `n` values of a dataset: they must all be stored in the file. A dataset
/// whose dataspace declares more values than its storage holds (never written, or a damaged
/// or hostile file) is refused, so its size cannot trigger a huge allocation.
void check_stored(hid_t object, const ObjectIo& io, std::uint64_t n, std::size_t value_size, hid_t type, const fs::path& file,
                  const std::string& label) {
  if (&io != &dataset_io || n == 0) return;
  const std::size_t stored_size = H5Tget_size(type);
  if (stored_size == 0) throw_error(file, "cannot get the value size of " + label);
  const hsize_t stored = H5Dget_storage_size(object);
  const std::uint64_t limit = std::numeric_limits<std::uint64_t>::max() / std::max(stored_size, value_size);
  if (n > limit || stored < n * stored_size)
    throw_error(file, label + " declares " + std::to_string(n) + " values but stores only " + std::to_string(stored) +
                          " bytes (never written, or a damaged file)");
}

/// Reads every value of a dataset or attribute, checking its type class first.
template <class T>
std::vector<T> read_values(hid_t object, const ObjectIo& io, hid_t mem_type, const fs::path& file, const std::string& label) {
  constexpr bool floating = std::is_floating_point_v<T>;
  Handle type = own(io.get_type(object), H5Tclose, file, "cannot get the type of " + label);
  if (H5Tget_class(type.get()) != (floating ? H5T_FLOAT : H5T_INTEGER))
    throw_error(file, label + " does not hold " + (floating ? "floating-point" : "integer") + " values");
  Handle space = own(io.get_space(object), H5Sclose, file, "cannot get the dataspace of " + label);
  const hssize_t n = H5Sget_simple_extent_npoints(space.get());
  if (n < 0) throw_error(file, "cannot count the values of " + label);
  check_stored(object, io, static_cast<std::uint64_t>(n), sizeof(T), type.get(), file, label);
  std::vector<T> values(static_cast<std::size_t>(n));
  if (n > 0) check(io.read(object, mem_type, values.data()), file, "cannot read " + label);
  return values;
}

/// Reads a fixed-length string written by write_string()/set_attribute(), byte for byte.
std::string read_text(hid_t object, const ObjectIo& io, const fs::path& file, const std::string& label) {
  Handle type = own(io.get_type(object), H5Tclose, file, "cannot get the type of " + label);
  if (H5Tget_class(type.get()) != H5T_STRING) throw_error(file, label + " does not hold a string");
  if (H5Tis_variable_str(type.get()) != 0)
    throw_error(file, label + " is a variable-length string (only fixed-length strings are supported)");
  Handle space = own(io.get_space(object), H5Sclose, file, "cannot get the dataspace of " + label);
  if (H5Sget_simple_extent_type(space.get()) == H5S_NULL) return {};
  if (H5Sget_simple_extent_npoints(space.get()) != 1) throw_error(file, label + " does not hold exactly one string");
  const std::size_t size = H5Tget_size(type.get());
  if (size == 0) throw_error(file, "cannot get the size of " + label);
  check_stored(object, io, 1, size, type.get(), file, label);
  std::string s(size, '\0');
  // Reading with the stored type itself: no conversion, every byte comes back unchanged.
  check(io.read(object, type.get(), s.data()), file, "cannot read " + label);
  return s;
}

template <class T>
T single_value(const std::vector<T>& values, const fs::path& file, const std::string& label) {
  if (values.size() != 1) throw_error(file, label + " holds " + std::to_string(values.size()) + " values, expected exactly one");
  return values[0];
}

}  // namespace

H5File H5File::create(const fs::path& path, std::size_t userblock) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle fcpl = own(H5Pcreate(H5P_FILE_CREATE), H5Pclose, path, "cannot create a property list");
  if (userblock > 0)
    check(H5Pset_userblock(fcpl.get(), userblock), path, "cannot reserve a user block of " + std::to_string(userblock) + " bytes");
  const hid_t id = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, fcpl.get(), H5P_DEFAULT);
  if (id < 0) throw_error(path, "cannot create the file");
  return H5File(path, id);
}

namespace {

/// The caller's image as the core driver's buffer: HDF5 would otherwise copy the image into the
/// property list and again into the driver (three copies of the file at the open). The callbacks
/// hand out the caller's bytes wherever HDF5 asks for a buffer of the image's size, make the copy
/// onto itself a no-op and never free them; anything else (a resize: the file is read-only) fails.
/// HDF5 copies the view (udata_copy) into each property list that holds the callbacks; the core
/// driver borrows the property list's, which only image_malloc reads, during the open.
struct ImageView {
  unsigned char* data;
  std::size_t size;
};
const H5FD_file_image_callbacks_t shared_image_callbacks{
    [](std::size_t size, H5FD_file_image_op_t, void* u) -> void* {
      const auto* v = static_cast<const ImageView*>(u);
      return size == v->size ? v->data : nullptr;
    },
    [](void* dest, const void* src, std::size_t, H5FD_file_image_op_t, void*) -> void* { return dest == src ? dest : nullptr; },
    [](void*, std::size_t, H5FD_file_image_op_t, void*) -> void* { return nullptr; },
    [](void*, H5FD_file_image_op_t, void*) -> herr_t { return 0; },
    [](void* u) -> void* { return new ImageView(*static_cast<const ImageView*>(u)); },
    [](void* u) -> herr_t {
      delete static_cast<ImageView*>(u);
      return 0;
    },
    nullptr};

}  // namespace

H5File H5File::open_image(const fs::path& path, std::span<const unsigned char> image) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (image.empty()) throw SetupError("HDF5 file '" + path.string() + "': the file image is empty");
  Handle fapl = own(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, path, "cannot create a property list");
  // Core (in-memory) driver without a backing store: nothing is ever written to disk.
  check(H5Pset_fapl_core(fapl.get(), 1 << 16, 0), path, "cannot select the in-memory driver");
  ImageView view{const_cast<unsigned char*>(image.data()), image.size()};
  H5FD_file_image_callbacks_t callbacks = shared_image_callbacks;
  callbacks.udata = &view;  // copied by udata_copy into each holder
  check(H5Pset_file_image_callbacks(fapl.get(), &callbacks), path, "cannot set the file image callbacks");
  check(H5Pset_file_image(fapl.get(), view.data, image.size()), path, "cannot set the file image");
  // The core driver refuses to open an image under the name of an existing file, so the image
  // gets a name below the file itself, which cannot exist (a regular file has no children).
  const fs::path image_name = path / "in-memory-image";
  const hid_t id = H5Fopen(image_name.c_str(), H5F_ACC_RDONLY, fapl.get());
  if (id < 0) throw_error(path, "cannot open the file image for reading");
  return H5File(path, id);
}

H5File H5File::open_read(const fs::path& path, const fs::path& open_as) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const fs::path& name = open_as.empty() ? path : open_as;
  std::error_code ec;
  if (!fs::exists(name, ec)) throw SetupError("HDF5 file '" + path.string() + "': file does not exist");
  const hid_t id = H5Fopen(name.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) throw_error(path, "cannot open the file for reading");
  return H5File(path, id);
}

namespace {
/// Closes a file and hands the memory HDF5's free lists kept from its reads and writes back to
/// the heap (H5garbage_collect): the library keeps freed blocks for reuse otherwise, up to
/// megabytes after a checkpoint (the main scenario's sweep held 1.7 MB of them at its peak).
herr_t close_file(hid_t id) {
  const herr_t rc = H5Fclose(id);
  H5garbage_collect();
  return rc;
}
}  // namespace

H5File::H5File(H5File&& other) noexcept : path_(std::move(other.path_)), id_(std::exchange(other.id_, -1)) {}

H5File& H5File::operator=(H5File&& other) noexcept {
  if (this != &other) {
    if (id_ >= 0) close_file(id_);
    path_ = std::move(other.path_);
    id_ = std::exchange(other.id_, -1);
  }
  return *this;
}

H5File::~H5File() {
  if (id_ >= 0) close_file(id_);
}

void H5File::close() {
  if (id_ < 0) return;
  const hid_t id = std::exchange(id_, -1);
  check(close_file(id), path_, "cannot close the file");
}

void H5File::require_open(const std::string& what) const {
  if (id_ < 0) throw SetupError("HDF5 file '" + path_.string() + "': cannot " + what + ": file is closed");
}

void H5File::fail(const std::string& what) const { throw_error(path_, what); }

bool H5File::exists(const std::string& path) const {
  require_open("look up '" + path + "'");
  std::string prefix;
  std::size_t begin = 0;
  while (begin < path.size()) {
    std::size_t end = path.find('/', begin);
    if (end == std::string::npos) end = path.size();
    if (end > begin) {
      prefix += '/';
      prefix.append(path, begin, end - begin);
      // Negative means a parent is not a group: the path does not exist either.
      if (H5Lexists(id_, prefix.c_str(), H5P_DEFAULT) <= 0) {
        H5Eclear2(H5E_DEFAULT);
        return false;
      }
    }
    begin = end + 1;
  }
  return true;
}

void H5File::create_group(const std::string& path) {
  require_open("create group '" + path + "'");
  if (exists(path)) {
    const hid_t g = H5Gopen2(id_, absolute(path).c_str(), H5P_DEFAULT);
    if (g < 0) fail("cannot create group '" + absolute(path) + "': a dataset of that name exists");
    H5Gclose(g);
    return;
  }
  Handle lcpl = own(H5Pcreate(H5P_LINK_CREATE), H5Pclose, path_, "cannot create a property list");
  check(H5Pset_create_intermediate_group(lcpl.get(), 1), path_, "cannot set intermediate group creation");
  own(H5Gcreate2(id_, absolute(path).c_str(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), H5Gclose, path_,
      "cannot create group '" + absolute(path) + "'");
}

std::vector<std::string> H5File::children(const std::string& group) const {
  require_open("list group '" + group + "'");
  if (!exists(group)) fail("no group '" + absolute(group) + "'");
  Handle g = own(H5Gopen2(id_, absolute(group).c_str(), H5P_DEFAULT), H5Gclose, path_, "cannot open group '" + absolute(group) + "'");
  std::vector<std::string> names;
  check(H5Literate(
            g.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr,
            [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
              static_cast<std::vector<std::string>*>(data)->emplace_back(name);
              return 0;
            },
            &names),
        path_, "cannot list group '" + absolute(group) + "'");
  return names;
}

std::vector<std::size_t> H5File::shape(const std::string& dataset) const {
  require_open("read " + dataset_label(dataset));
  if (!exists(dataset)) fail("no " + dataset_label(dataset));
  Handle d = own(H5Dopen2(id_, absolute(dataset).c_str(), H5P_DEFAULT), H5Dclose, path_, "cannot open " + dataset_label(dataset));
  Handle space = own(H5Dget_space(d.get()), H5Sclose, path_, "cannot get the dataspace of " + dataset_label(dataset));
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail("cannot get the rank of " + dataset_label(dataset));
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    fail("cannot get the dimensions of " + dataset_label(dataset));
  return std::vector<std::size_t>(dims.begin(), dims.end());
}

void H5File::create_external_link(const std::string& path, const std::string& target_file, const std::string& target_object) {
  require_open("create link '" + absolute(path) + "'");
  if (exists(path)) fail("cannot create link '" + absolute(path) + "': it already exists");
  Handle lcpl = own(H5Pcreate(H5P_LINK_CREATE), H5Pclose, path_, "cannot create a property list");
  check(H5Pset_create_intermediate_group(lcpl.get(), 1), path_, "cannot set intermediate group creation");
  check(H5Lcreate_external(target_file.c_str(), target_object.c_str(), id_, absolute(path).c_str(), lcpl.get(), H5P_DEFAULT), path_,
        "cannot create link '" + absolute(path) + "' to '" + target_file + ":" + target_object + "'");
}

namespace {

/// Creates a dataset (and missing parent groups) and writes `buffer` into it.
void write_dataset(hid_t file_id, const fs::path& file, const std::string& path, hid_t file_type, hid_t mem_type, hid_t space,
                   const void* buffer, bool has_data) {
  Handle lcpl = own(H5Pcreate(H5P_LINK_CREATE), H5Pclose, file, "cannot create a property list");
  check(H5Pset_create_intermediate_group(lcpl.get(), 1), file, "cannot set intermediate group creation");
  Handle d = own(H5Dcreate2(file_id, absolute(path).c_str(), file_type, space, lcpl.get(), H5P_DEFAULT, H5P_DEFAULT), H5Dclose, file,
                 "cannot create " + dataset_label(path));
  if (has_data) check(dataset_io.write(d.get(), mem_type, buffer), file, "cannot write " + dataset_label(path));
}

/// Dataspace of an array dataset: 1-D when components == 0, else rows x components.
Handle array_space(std::size_t size, int components, const fs::path& file, const std::string& path) {
  if (components < 0) throw_error(file, "cannot write " + dataset_label(path) + ": negative number of components");
  if (components == 0) {
    const hsize_t dims[1] = {size};
    return own(H5Screate_simple(1, dims, nullptr), H5Sclose, file, "cannot create a dataspace");
  }
  const auto c = static_cast<std::size_t>(components);
  if (size % c != 0)
    throw_error(file, "cannot write " + dataset_label(path) + ": " + std::to_string(size) + " values are not a multiple of " +
                          std::to_string(c) + " components");
  const hsize_t dims[2] = {size / c, c};
  return own(H5Screate_simple(2, dims, nullptr), H5Sclose, file, "cannot create a dataspace");
}

}  // namespace

void H5File::write(const std::string& path, std::span<const double> data, int components) {
  require_open("write " + dataset_label(path));
  if (exists(path)) fail("cannot write " + dataset_label(path) + ": it already exists");
  Handle space = array_space(data.size(), components, path_, path);
  write_dataset(id_, path_, path, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(), data.data(), !data.empty());
}

void H5File::write(const std::string& path, std::span<const std::int64_t> data, int components) {
  require_open("write " + dataset_label(path));
  if (exists(path)) fail("cannot write " + dataset_label(path) + ": it already exists");
  Handle space = array_space(data.size(), components, path_, path);
  write_dataset(id_, path_, path, H5T_STD_I64LE, H5T_NATIVE_INT64, space.get(), data.data(), !data.empty());
}

void H5File::write_scalar(const std::string& path, double x) {
  require_open("write " + dataset_label(path));
  if (exists(path)) fail("cannot write " + dataset_label(path) + ": it already exists");
  Handle space = scalar_space(path_);
  write_dataset(id_, path_, path, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(), &x, true);
}

void H5File::write_scalar(const std::string& path, std::int64_t x) {
  require_open("write " + dataset_label(path));
  if (exists(path)) fail("cannot write " + dataset_label(path) + ": it already exists");
  Handle space = scalar_space(path_);
  write_dataset(id_, path_, path, H5T_STD_I64LE, H5T_NATIVE_INT64, space.get(), &x, true);
}

void H5File::write_string(const std::string& path, const std::string& s) {
  require_open("write " + dataset_label(path));
  if (exists(path)) fail("cannot write " + dataset_label(path) + ": it already exists");
  Handle type = string_type(s.size(), path_);
  Handle space = string_space(s, path_);
  write_dataset(id_, path_, path, type.get(), type.get(), space.get(), s.data(), !s.empty());
}

std::vector<double> H5File::read_doubles(const std::string& path) const {
  require_open("read " + dataset_label(path));
  if (!exists(path)) fail("no " + dataset_label(path));
  Handle d = own(H5Dopen2(id_, absolute(path).c_str(), H5P_DEFAULT), H5Dclose, path_, "cannot open " + dataset_label(path));
  return read_values<double>(d.get(), dataset_io, H5T_NATIVE_DOUBLE, path_, dataset_label(path));
}

std::vector<std::int64_t> H5File::read_int64s(const std::string& path) const {
  require_open("read " + dataset_label(path));
  if (!exists(path)) fail("no " + dataset_label(path));
  Handle d = own(H5Dopen2(id_, absolute(path).c_str(), H5P_DEFAULT), H5Dclose, path_, "cannot open " + dataset_label(path));
  return read_values<std::int64_t>(d.get(), dataset_io, H5T_NATIVE_INT64, path_, dataset_label(path));
}

double H5File::read_double(const std::string& path) const { return single_value(read_doubles(path), path_, dataset_label(path)); }

std::int64_t H5File::read_int64(const std::string& path) const { return single_value(read_int64s(path), path_, dataset_label(path)); }

std::string H5File::read_string(const std::string& path) const {
  require_open("read " + dataset_label(path));
  if (!exists(path)) fail("no " + dataset_label(path));
  Handle d = own(H5Dopen2(id_, absolute(path).c_str(), H5P_DEFAULT), H5Dclose, path_, "cannot open " + dataset_label(path));
  return read_text(d.get(), dataset_io, path_, dataset_label(path));
}

namespace {

/// Creates (replacing any previous one) an attribute on an existing object and writes it.
void write_attribute(hid_t file_id, const fs::path& file, const std::string& object, const std::string& name, hid_t file_type,
                     hid_t mem_type, hid_t space, const void* buffer, bool has_data) {
  const std::string obj = absolute(object);
  const htri_t present = H5Aexists_by_name(file_id, obj.c_str(), name.c_str(), H5P_DEFAULT);
  if (present < 0) throw_error(file, "cannot look up " + attribute_label(object, name));
  if (present > 0)
    check(H5Adelete_by_name(file_id, obj.c_str(), name.c_str(), H5P_DEFAULT), file, "cannot replace " + attribute_label(object, name));
  Handle a = own(H5Acreate_by_name(file_id, obj.c_str(), name.c_str(), file_type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                 file, "cannot create " + attribute_label(object, name));
  if (has_data) check(attribute_io.write(a.get(), mem_type, buffer), file, "cannot write " + attribute_label(object, name));
}

}  // namespace

void H5File::set_attribute(const std::string& object, const std::string& name, double x) {
  require_open("write " + attribute_label(object, name));
  if (!exists(object)) fail("cannot write " + attribute_label(object, name) + ": no such object");
  Handle space = scalar_space(path_);
  write_attribute(id_, path_, object, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, space.get(), &x, true);
}

void H5File::set_attribute(const std::string& object, const std::string& name, std::int64_t x) {
  require_open("write " + attribute_label(object, name));
  if (!exists(object)) fail("cannot write " + attribute_label(object, name) + ": no such object");
  Handle space = scalar_space(path_);
  write_attribute(id_, path_, object, name, H5T_STD_I64LE, H5T_NATIVE_INT64, space.get(), &x, true);
}

void H5File::set_attribute(const std::string& object, const std::string& name, const std::string& s) {
  require_open("write " + attribute_label(object, name));
  if (!exists(object)) fail("cannot write " + attribute_label(object, name) + ": no such object");
  Handle type = string_type(s.size(), path_);
  Handle space = string_space(s, path_);
  write_attribute(id_, path_, object, name, type.get(), type.get(), space.get(), s.data(), !s.empty());
}

bool H5File::has_attribute(const std::string& object, const std::string& name) const {
  require_open("look up " + attribute_label(object, name));
  if (!exists(object)) return false;
  const htri_t present = H5Aexists_by_name(id_, absolute(object).c_str(), name.c_str(), H5P_DEFAULT);
  if (present < 0) fail("cannot look up " + attribute_label(object, name));
  return present > 0;
}

namespace {

Handle open_attribute(hid_t file_id, const fs::path& file, const std::string& object, const std::string& name) {
  const hid_t id = H5Aopen_by_name(file_id, absolute(object).c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT);
  return own(id, H5Aclose, file, "cannot open " + attribute_label(object, name));
}

}  // namespace

double H5File::attribute_double(const std::string& object, const std::string& name) const {
  if (!has_attribute(object, name)) fail("no " + attribute_label(object, name));
  Handle a = open_attribute(id_, path_, object, name);
  const std::string label = attribute_label(object, name);
  return single_value(read_values<double>(a.get(), attribute_io, H5T_NATIVE_DOUBLE, path_, label), path_, label);
}

std::int64_t H5File::attribute_int64(const std::string& object, const std::string& name) const {
  if (!has_attribute(object, name)) fail("no " + attribute_label(object, name));
  Handle a = open_attribute(id_, path_, object, name);
  const std::string label = attribute_label(object, name);
  return single_value(read_values<std::int64_t>(a.get(), attribute_io, H5T_NATIVE_INT64, path_, label), path_, label);
}

std::string H5File::attribute_string(const std::string& object, const std::string& name) const {
  if (!has_attribute(object, name)) fail("no " + attribute_label(object, name));
  Handle a = open_attribute(id_, path_, object, name);
  return read_text(a.get(), attribute_io, path_, attribute_label(object, name));
}

}  // namespace sparkdem::io
