#pragma once
/// Mutations of sealed checkpoints for fuzzing the restart reader (tests/fuzz/fuzz_driver.cpp,
/// tests/scenario/test_fuzz_checkpoint.cpp).
///
/// A checkpoint is read into a model (every dataset: kind, dimensions, values) through the plain
/// HDF5 C API; structure-aware mutations change the model (values set to NaN / inf / huge /
/// negative / off-by-one, rows added or dropped, columns or rank changed, type changed, items
/// deleted or swapped, strings cut, extended or scrambled, a huge dataset declared but never
/// written), and the model is written back as a new HDF5 file. Byte-level mutations change the
/// HDF5 bytes themselves (flips, special words, truncation, block copies, insertions, zeroed
/// runs). Either way the result is RE-SEALED with a valid header (io::seal_checkpoint), so the
/// checksum passes and the mutation reaches HDF5 and the archive reader.
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/restart/checkpoint_file.hpp"

namespace sparkdem::test {

/// One dataset of a checkpoint.
struct CkptItem {
  enum class Kind { Float, Int, String };
  Kind kind = Kind::Float;
  std::vector<hsize_t> dims;    ///< empty: scalar dataspace
  std::vector<double> f;        ///< Float values (row-major)
  std::vector<std::int64_t> i;  ///< Int values
  std::string s;                ///< String (empty: null dataspace)
  bool unwritten = false;       ///< declared with `dims` but no data written (storage never allocated)
};
using CkptModel = std::map<std::string, CkptItem>;  ///< by path without the leading '/'

namespace ckpt_detail {
inline void fail(const std::string& what) { throw std::runtime_error("checkpoint model: " + what); }

inline void collect(hid_t file, const std::string& group, std::vector<std::string>& out) {
  const hid_t g = H5Gopen2(file, group.c_str(), H5P_DEFAULT);
  if (g < 0) fail("cannot open group " + group);
  H5G_info_t info;
  H5Gget_info(g, &info);
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    char name[1024];
    H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, k, name, sizeof name, H5P_DEFAULT);
    const std::string child = (group == "/" ? "" : group) + "/" + name;
    const hid_t o = H5Oopen(file, child.c_str(), H5P_DEFAULT);
    const H5I_type_t t = H5Iget_type(o);
    H5Oclose(o);
    if (t == H5I_GROUP)
      collect(file, child, out);
    else if (t == H5I_DATASET)
      out.push_back(child.substr(1));
  }
  H5Gclose(g);
}

inline std::size_t count(const std::vector<hsize_t>& dims) {
  std::size_t n = 1;
  for (hsize_t d : dims) n *= static_cast<std::size_t>(d);
  return n;
}
}  // namespace ckpt_detail

/// Reads every dataset of a (valid) checkpoint file.
inline CkptModel read_checkpoint_model(const std::filesystem::path& file) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) ckpt_detail::fail("cannot open " + file.string());
  std::vector<std::string> names;
  ckpt_detail::collect(f, "/", names);
  CkptModel m;
  for (const auto& n : names) {
    const hid_t d = H5Dopen2(f, ("/" + n).c_str(), H5P_DEFAULT);
    const hid_t t = H5Dget_type(d);
    const hid_t sp = H5Dget_space(d);
    CkptItem it;
    const bool null_space = H5Sget_simple_extent_type(sp) == H5S_NULL;
    const int rank = null_space ? 0 : H5Sget_simple_extent_ndims(sp);
    it.dims.resize(static_cast<std::size_t>(std::max(rank, 0)));
    if (rank > 0) H5Sget_simple_extent_dims(sp, it.dims.data(), nullptr);
    const std::size_t npts = null_space ? 0 : ckpt_detail::count(it.dims);
    switch (H5Tget_class(t)) {
      case H5T_FLOAT:
        it.kind = CkptItem::Kind::Float;
        it.f.resize(npts);
        if (npts) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, it.f.data());
        break;
      case H5T_INTEGER:
        it.kind = CkptItem::Kind::Int;
        it.i.resize(npts);
        if (npts) H5Dread(d, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, it.i.data());
        break;
      case H5T_STRING:
        it.kind = CkptItem::Kind::String;
        if (!null_space) {
          it.s.assign(H5Tget_size(t), '\0');
          H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, it.s.data());
        }
        break;
      default:
        ckpt_detail::fail("unexpected type class of " + n);
    }
    H5Sclose(sp);
    H5Tclose(t);
    H5Dclose(d);
    m[n] = std::move(it);
  }
  H5Fclose(f);
  return m;
}

/// Writes a model as an HDF5 file with a 512-byte user block and seals it (valid checksum).
/// Throws std::runtime_error when HDF5 refuses the model (e.g. a dataspace too large to describe);
/// every HDF5 object is closed either way (a file left open would make every later write fail).
inline void write_checkpoint_model(const CkptModel& m, const std::filesystem::path& file) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t fcpl = H5Pcreate(H5P_FILE_CREATE);
  H5Pset_userblock(fcpl, io::kCheckpointHeaderBytes);
  const hid_t fapl = H5Pcreate(H5P_FILE_ACCESS);
  H5Pset_fclose_degree(fapl, H5F_CLOSE_STRONG);  // closing the file closes whatever is still open in it
  const hid_t f = H5Fcreate(file.c_str(), H5F_ACC_TRUNC, fcpl, fapl);
  H5Pclose(fcpl);
  H5Pclose(fapl);
  if (f < 0) ckpt_detail::fail("cannot create " + file.string());
  const hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  std::string error;
  for (const auto& [name, it] : m) {
    hid_t type, space;
    const void* data = nullptr;
    if (it.kind == CkptItem::Kind::String) {
      type = H5Tcopy(H5T_C_S1);
      H5Tset_size(type, std::max<std::size_t>(it.s.size(), 1));
      H5Tset_strpad(type, H5T_STR_NULLPAD);
      H5Tset_cset(type, H5T_CSET_UTF8);
      space = H5Screate(it.s.empty() ? H5S_NULL : H5S_SCALAR);
      if (!it.s.empty()) data = it.s.data();
    } else {
      type = H5Tcopy(it.kind == CkptItem::Kind::Float ? H5T_IEEE_F64LE : H5T_STD_I64LE);
      space = it.dims.empty() ? H5Screate(H5S_SCALAR) : H5Screate_simple(static_cast<int>(it.dims.size()), it.dims.data(), nullptr);
      const std::size_t n = it.dims.empty() ? 1 : ckpt_detail::count(it.dims);
      const std::size_t have = it.kind == CkptItem::Kind::Float ? it.f.size() : it.i.size();
      if (!it.unwritten && n > 0) {
        if (have != n) ckpt_detail::fail("item " + name + " holds " + std::to_string(have) + " values for " + std::to_string(n));
        data = it.kind == CkptItem::Kind::Float ? static_cast<const void*>(it.f.data()) : static_cast<const void*>(it.i.data());
      }
    }
    const hid_t d = space < 0 ? -1 : H5Dcreate2(f, ("/" + name).c_str(), type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
    if (d < 0) error = "cannot create dataset " + name;
    if (d >= 0 && data != nullptr) {
      const hid_t mem = it.kind == CkptItem::Kind::String ? type : it.kind == CkptItem::Kind::Float ? H5T_NATIVE_DOUBLE : H5T_NATIVE_INT64;
      if (H5Dwrite(d, mem, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0) error = "cannot write dataset " + name;
    }
    if (d >= 0) H5Dclose(d);
    if (space >= 0) H5Sclose(space);
    H5Tclose(type);
    if (!error.empty()) break;
  }
  H5Pclose(lcpl);
  if (H5Fclose(f) < 0 && error.empty()) error = "cannot close " + file.string();
  if (!error.empty()) ckpt_detail::fail(error);
  io::seal_checkpoint(file);
}

/// The bytes of a file.
inline std::vector<unsigned char> file_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(in)), {});
}

/// Writes `payload` (HDF5 bytes, user block included; at least 512 bytes) and seals it.
inline void write_sealed_bytes(std::vector<unsigned char> bytes, const std::filesystem::path& file) {
  if (bytes.size() < io::kCheckpointHeaderBytes) bytes.resize(io::kCheckpointHeaderBytes, 0);
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  io::seal_checkpoint(file);
}

/// Seeded mutator. Every mutation returns a one-line description (the recipe of the case).
class CheckpointMutator {
 public:
  explicit CheckpointMutator(std::uint64_t seed) : rng_(seed) {}
  std::size_t pick(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng_() % n); }
  std::mt19937_64& rng() { return rng_; }

  /// 1 to 3 structure-aware mutations of the model.
  std::string mutate_model(CkptModel& m) {
    std::string what;
    const std::size_t n = 1 + (pick(3) == 0 ? 1 + pick(2) : 0);
    for (std::size_t k = 0; k < n && !m.empty(); ++k) what += (k ? "; " : "") + mutate_once(m);
    return what;
  }

  /// One byte-level mutation of the HDF5 payload (bytes after the 512-byte header).
  std::string mutate_bytes(std::vector<unsigned char>& b) {
    const std::size_t h = io::kCheckpointHeaderBytes;
    if (b.size() <= h + 16) return "noop";
    const std::size_t len = b.size() - h;
    // Offsets are drawn near the start half the time: HDF5's superblock and root metadata live there.
    auto offset = [&] { return h + (pick(2) ? pick(std::min<std::size_t>(len, 4096)) : pick(len)); };
    switch (pick(7)) {
      case 0: {
        const std::size_t k = 1 + pick(8);
        std::string w = "flip " + std::to_string(k) + " bytes at";
        for (std::size_t q = 0; q < k; ++q) {
          const std::size_t at = offset();
          b[at] ^= static_cast<unsigned char>(1u << pick(8));
          w += " " + std::to_string(at);
        }
        return w;
      }
      case 1: {
        const std::size_t at = offset();
        const std::uint64_t words[] = {0,
                                       ~0ULL,
                                       0x7fffffffffffffffULL,
                                       0x8000000000000000ULL,
                                       0xffffffffULL,
                                       0x100000000ULL,
                                       1ULL << 40,
                                       static_cast<std::uint64_t>(rng_())};
        const std::uint64_t w = words[pick(8)];
        const std::size_t width = std::size_t{1} << pick(4);  // 1, 2, 4 or 8 bytes
        for (std::size_t q = 0; q < width && at + q < b.size(); ++q) b[at + q] = static_cast<unsigned char>(w >> (8 * q));
        return "set " + std::to_string(width) + " bytes at " + std::to_string(at) + " from word " + std::to_string(w);
      }
      case 2: {
        const std::size_t keep = h + pick(len);
        b.resize(keep);
        return "truncate to " + std::to_string(keep) + " bytes";
      }
      case 3: {
        const std::size_t from = offset(), to = offset(), n = 1 + pick(std::min<std::size_t>(256, b.size() - std::max(from, to)));
        std::memmove(b.data() + to, b.data() + from, std::min(n, b.size() - std::max(from, to)));
        return "copy " + std::to_string(n) + " bytes from " + std::to_string(from) + " to " + std::to_string(to);
      }
      case 4: {
        const std::size_t at = offset(), n = 1 + pick(64);
        std::vector<unsigned char> ins(n);
        for (auto& c : ins) c = static_cast<unsigned char>(rng_());
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), ins.begin(), ins.end());
        return "insert " + std::to_string(n) + " random bytes at " + std::to_string(at);
      }
      case 5: {
        const std::size_t at = offset(), n = std::min<std::size_t>(1 + pick(512), b.size() - at);
        std::fill(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at + n), 0);
        return "zero " + std::to_string(n) + " bytes at " + std::to_string(at);
      }
      default: {
        const std::size_t at = offset(), n = std::min<std::size_t>(1 + pick(128), b.size() - at);
        b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), b.begin() + static_cast<std::ptrdiff_t>(at),
                 b.begin() + static_cast<std::ptrdiff_t>(at + n));
        return "duplicate " + std::to_string(n) + " bytes at " + std::to_string(at);
      }
    }
  }

 private:
  using Kind = CkptItem::Kind;

  std::string name_of(const CkptModel& m, std::size_t k) {
    auto it = m.begin();
    std::advance(it, static_cast<std::ptrdiff_t>(k % m.size()));
    return it->first;
  }
  /// A random item name, preferring those of `kind` when asked.
  std::string any(const CkptModel& m, int kind = -1) {
    std::vector<std::string> c;
    for (const auto& [n, it] : m)
      if (kind < 0 || static_cast<int>(it.kind) == kind) c.push_back(n);
    if (c.empty()) return name_of(m, pick(m.size()));
    return c[pick(c.size())];
  }
  double odd_double(double v) {
    switch (pick(16)) {
      case 0:
        return std::numeric_limits<double>::quiet_NaN();
      case 1:
        return std::numeric_limits<double>::infinity();
      case 2:
        return -std::numeric_limits<double>::infinity();
      case 3:
        return 0.0;
      case 4:
        return -0.0;
      case 5:
        return 1e308;
      case 6:
        return -1e308;
      case 7:
        return 4.9e-324;
      case 8:
        return -v;
      case 9:
        return v * 1e10;
      case 10:
        return v * 1e-10;
      case 11:
        return std::nextafter(v, 1e300);
      case 12:
        return -1.0;
      case 13:
        return 1e19;
      case 14:
        return 9.3e18;
      default:
        return static_cast<double>(static_cast<std::int64_t>(rng_() % 2001) - 1000);
    }
  }
  std::int64_t odd_int(std::int64_t v, const CkptModel& m) {
    std::int64_t n = 0;
    if (auto it = m.find("state/particles/id"); it != m.end()) n = static_cast<std::int64_t>(it->second.i.size());
    switch (pick(16)) {
      case 0:
        return 0;
      case 1:
        return -1;
      case 2:
        return 1;
      case 3:
        return std::numeric_limits<std::int64_t>::min();
      case 4:
        return std::numeric_limits<std::int64_t>::max();
      case 5:
        return v + 1;
      case 6:
        return v - 1;
      case 7:
        return v * 2;
      case 8:
        return -v;
      case 9:
        return n;
      case 10:
        return n + 1;
      case 11:
        return std::int64_t{1} << 31;
      case 12:
        return std::int64_t{1} << 32;
      case 13:
        return std::int64_t{1} << 62;
      case 14:
        return static_cast<std::int64_t>(rng_());
      default:
        return static_cast<std::int64_t>(pick(2 * static_cast<std::size_t>(n) + 4));
    }
  }
  static std::size_t rows_of(const CkptItem& it) { return it.dims.empty() ? 1 : static_cast<std::size_t>(it.dims[0]); }
  static std::size_t row_width(const CkptItem& it) {
    std::size_t w = 1;
    for (std::size_t k = 1; k < it.dims.size(); ++k) w *= static_cast<std::size_t>(it.dims[k]);
    return w;
  }
  /// Resizes the value vector of a numeric item to `n` values (new values copy old ones or are 0).
  void resize_values(CkptItem& it, std::size_t n) {
    if (it.kind == Kind::Float) {
      const std::size_t old = it.f.size();
      it.f.resize(n);
      for (std::size_t k = old; k < n; ++k) it.f[k] = old ? it.f[k % old] : 0.0;
    } else {
      const std::size_t old = it.i.size();
      it.i.resize(n);
      for (std::size_t k = old; k < n; ++k) it.i[k] = old ? it.i[k % old] : 0;
    }
  }

  std::string mutate_once(CkptModel& m) {
    switch (pick(10)) {
      case 0:
      case 1: {  // odd values
        const std::string n = any(m, pick(2) ? static_cast<int>(Kind::Float) : static_cast<int>(Kind::Int));
        CkptItem& it = m[n];
        const std::size_t size = it.kind == Kind::Float ? it.f.size() : it.kind == Kind::Int ? it.i.size() : 0;
        if (size == 0) return "noop (" + n + " empty)";
        const bool all = pick(5) == 0;
        const std::size_t first = pick(size);
        std::string w = "set " + std::string(all ? "every value" : "value " + std::to_string(first)) + " of " + n + " to ";
        for (std::size_t k = all ? 0 : first; k < (all ? size : first + 1); ++k) {
          if (it.kind == Kind::Float) {
            it.f[k] = (all && k > 0) ? it.f[0] : odd_double(it.f[k]);
            if (k == (all ? 0 : first)) w += std::to_string(it.f[k]);
          } else {
            it.i[k] = (all && k > 0) ? it.i[0] : odd_int(it.i[k], m);
            if (k == (all ? 0 : first)) w += std::to_string(it.i[k]);
          }
        }
        return w;
      }
      case 2: {  // rows
        const std::string n = any(m);
        CkptItem& it = m[n];
        if (it.kind == Kind::String || it.dims.empty()) return "noop (" + n + " not an array)";
        const std::size_t r = rows_of(it);
        const std::size_t choices[] = {0, 1, r > 0 ? r - 1 : 0, r + 1, 2 * r, r / 2, pick(2 * r + 10)};
        const std::size_t rows = choices[pick(7)];
        it.dims[0] = rows;
        resize_values(it, rows * row_width(it));
        return "resize " + n + " to " + std::to_string(rows) + " rows (was " + std::to_string(r) + ")";
      }
      case 3: {  // shape
        const std::string n = any(m);
        CkptItem& it = m[n];
        if (it.kind == Kind::String) return "noop (" + n + " is a string)";
        const std::size_t total = it.kind == Kind::Float ? it.f.size() : it.i.size();
        const hsize_t widths[] = {1, 2, 3, 4, 7, 13};
        switch (pick(4)) {
          case 0:
            it.dims = {};
            resize_values(it, 1);
            return "make " + n + " a scalar";
          case 1:
            it.dims = {static_cast<hsize_t>(total)};
            return "make " + n + " 1-D";
          case 2: {
            const hsize_t c = widths[pick(6)];
            it.dims = {static_cast<hsize_t>(total / c), c};
            resize_values(it, static_cast<std::size_t>(it.dims[0] * c));
            return "make " + n + " (rows, " + std::to_string(c) + ")";
          }
          default:
            it.dims = {static_cast<hsize_t>(total), 1, 1};
            return "make " + n + " 3-D";
        }
      }
      case 4: {  // type
        const std::string n = any(m);
        CkptItem& it = m[n];
        if (it.kind == Kind::Float) {
          it.kind = Kind::Int;
          it.i.assign(it.f.size(), 0);
          for (std::size_t k = 0; k < it.f.size(); ++k)
            it.i[k] = std::isfinite(it.f[k]) && std::abs(it.f[k]) < 9e18 ? static_cast<std::int64_t>(it.f[k]) : 0;
          return "make " + n + " integer";
        }
        if (it.kind == Kind::Int && pick(2)) {
          it.kind = Kind::Float;
          it.f.assign(it.i.begin(), it.i.end());
          return "make " + n + " floating-point";
        }
        if (it.kind == Kind::Int) {
          it.kind = Kind::String;
          it.s = it.i.empty() ? "" : std::to_string(it.i[0]);
          it.dims = {};
          return "make " + n + " a string";
        }
        it.kind = Kind::Float;
        it.f = {1.0, 2.0};
        it.dims = {2};
        it.s.clear();
        return "make string " + n + " a 1-D float array";
      }
      case 5: {  // delete
        const std::string n = any(m);
        m.erase(n);
        return "delete " + n;
      }
      case 6: {  // swap two items
        const std::string a = any(m), b = any(m);
        std::swap(m[a], m[b]);
        return "swap " + a + " and " + b;
      }
      case 7: {  // declared, never written, huge
        const std::string n = any(m, pick(2) ? static_cast<int>(Kind::Float) : static_cast<int>(Kind::Int));
        CkptItem& it = m[n];
        if (it.kind == Kind::String) return "noop (" + n + " is a string)";
        const hsize_t huge[] = {hsize_t{1} << 24, hsize_t{1} << 31, hsize_t{1} << 40, hsize_t{1} << 58};
        const hsize_t rows = huge[pick(4)];
        const hsize_t w = it.dims.size() >= 2 ? it.dims[1] : 0;
        it.dims = w ? std::vector<hsize_t>{rows, w} : std::vector<hsize_t>{rows};
        it.unwritten = true;
        return "declare " + n + " with " + std::to_string(rows) + " rows, data never written";
      }
      default: {  // strings
        const std::string n = any(m, static_cast<int>(Kind::String));
        CkptItem& it = m[n];
        if (it.kind != Kind::String) return "noop (no string)";
        std::string& s = it.s;
        switch (pick(8)) {
          case 0: {
            const std::size_t cut = pick(s.size() + 1);
            s.resize(cut);
            return "cut string " + n + " to " + std::to_string(cut) + " bytes";
          }
          case 1:
            s.clear();
            return "empty string " + n;
          case 2: {
            const char* inserts[] = {"\n", "|", "||", "\n\n", "x|y|z|w\n", "a|99999999999999999999|u|1\n", "a|-5|u|1\n",
                                     "{",  "}", " ",  "\0",   "-1",        "99999999999999999999999",      "nan"};
            const std::string ins = inserts[pick(14)];
            const std::size_t at = pick(s.size() + 1);
            s.insert(at, ins.empty() ? std::string(1, '\0') : ins);
            return "insert '" + ins + "' into string " + n + " at " + std::to_string(at);
          }
          case 3: {
            if (s.empty()) return "noop (empty string " + n + ")";
            const std::size_t at = pick(s.size());
            s[at] = static_cast<char>(rng_());
            return "change byte " + std::to_string(at) + " of string " + n;
          }
          case 4: {  // duplicate a line
            const std::size_t a = s.find('\n');
            if (a == std::string::npos) return "noop (one-line string " + n + ")";
            s.insert(0, s.substr(0, a + 1));
            return "duplicate the first line of string " + n;
          }
          case 5: {  // delete a line
            const std::size_t a = s.find('\n');
            if (a == std::string::npos) return "noop (one-line string " + n + ")";
            s.erase(0, a + 1);
            return "delete the first line of string " + n;
          }
          case 6: {
            std::string r(1 + pick(200), ' ');
            for (auto& c : r) c = static_cast<char>(rng_());
            s = r;
            return "replace string " + n + " by random bytes";
          }
          default: {  // numbers in the text made odd (rng state, JSON records)
            for (std::size_t k = 0; k < s.size(); ++k)
              if (s[k] >= '0' && s[k] <= '9' && pick(4) == 0) {
                const char* reps[] = {"-", "99999999999999999999999", "1e999", "x", ""};
                s.replace(k, 1, reps[pick(5)]);
                return "replace a digit of string " + n + " at " + std::to_string(k);
              }
            return "noop (no digit in " + n + ")";
          }
        }
      }
    }
  }

  std::mt19937_64 rng_;
};

}  // namespace sparkdem::test
