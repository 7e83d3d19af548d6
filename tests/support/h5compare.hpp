#pragma once
/// Bit-for-bit comparison of HDF5 files, through the plain HDF5 C API (independent of the
/// project's own H5File wrapper): every dataset's type class and size, dimensions and raw bytes.
#include <catch2/catch.hpp>
#include <hdf5.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace sparkdem::test {

/// One dataset: datatype description, dims, raw bytes in the file's type.
struct RawDataset {
  std::string type;
  std::vector<hsize_t> dims;
  std::vector<unsigned char> bytes;
};

/// Names of every dataset below `group` (recursive, portable HDF5 1.10/1.12 calls only).
inline void collect_datasets(hid_t file, const std::string& group, std::vector<std::string>& out) {
  const hid_t g = H5Gopen2(file, group.c_str(), H5P_DEFAULT);
  REQUIRE(g >= 0);
  H5G_info_t info;
  REQUIRE(H5Gget_info(g, &info) >= 0);
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    char name[512];
    REQUIRE(H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, k, name, sizeof name, H5P_DEFAULT) > 0);
    const std::string child = (group == "/" ? "" : group) + "/" + name;
    const hid_t o = H5Oopen(file, child.c_str(), H5P_DEFAULT);
    const H5I_type_t t = H5Iget_type(o);
    H5Oclose(o);
    if (t == H5I_GROUP)
      collect_datasets(file, child, out);
    else if (t == H5I_DATASET)
      out.push_back(child.substr(1));
  }
  H5Gclose(g);
}

/// Every dataset of an HDF5 file, by name (without the leading '/').
inline std::map<std::string, RawDataset> read_all(const std::filesystem::path& file) {
  std::map<std::string, RawDataset> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  INFO("opening " << file);
  REQUIRE(f >= 0);
  std::vector<std::string> names;
  collect_datasets(f, "/", names);
  for (const auto& n : names) {
    const hid_t d = H5Dopen2(f, n.c_str(), H5P_DEFAULT);
    const hid_t t = H5Dget_type(d);
    const hid_t sp = H5Dget_space(d);
    RawDataset r;
    const int rank = H5Sget_simple_extent_ndims(sp);
    r.dims.resize(rank > 0 ? rank : 0);
    if (rank > 0) H5Sget_simple_extent_dims(sp, r.dims.data(), nullptr);
    const hssize_t npts = H5Sget_simple_extent_type(sp) == H5S_NULL ? 0 : H5Sget_simple_extent_npoints(sp);
    const std::size_t tsize = H5Tget_size(t);
    r.type = std::to_string(H5Tget_class(t)) + ":" + std::to_string(tsize);
    r.bytes.resize(static_cast<std::size_t>(npts) * tsize);
    if (npts > 0) REQUIRE(H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.bytes.data()) >= 0);
    out[n] = std::move(r);
    H5Sclose(sp);
    H5Tclose(t);
    H5Dclose(d);
  }
  H5Fclose(f);
  return out;
}

/// The pipeline record (a fixed-length string dataset holding JSON) without the output folder's
/// bookkeeping, "outputs" and "sweep_outputs" (frame and row counts, the summary's stage entries
/// with their wall times: OutputObserver::outputs in io/scenario/pipeline.cpp), which describes the
/// folder a state file was written into, not the state.
inline nlohmann::json record_without_outputs(const RawDataset& d) {
  std::string text(d.bytes.begin(), d.bytes.end());
  text.erase(std::find(text.begin(), text.end(), '\0'), text.end());
  nlohmann::json j = nlohmann::json::parse(text);
  if (j.is_object()) {
    j.erase("outputs");
    j.erase("sweep_outputs");
  }
  return j;
}

/// Bit-for-bit comparison of every dataset of two files; the `required` datasets must exist.
/// Datasets named in `skip` must exist in both but are compared by the caller (e.g. records
/// holding output paths, which differ between two runs by construction). The pipeline record
/// (unless skipped) is compared as JSON without the folder's bookkeeping (record_without_outputs).
inline void require_identical_files(const std::filesystem::path& a, const std::filesystem::path& b,
                                    const std::vector<std::string>& required, const std::vector<std::string>& skip_given = {}) {
  const auto da = read_all(a), db = read_all(b);
  std::vector<std::string> skip = skip_given;
  if (std::find(skip.begin(), skip.end(), "pipeline/record") == skip.end() && da.count("pipeline/record") && db.count("pipeline/record")) {
    skip.push_back("pipeline/record");
    INFO("pipeline/record of " << a << " vs " << b << " (less outputs, sweep_outputs)");
    CHECK(record_without_outputs(da.at("pipeline/record")) == record_without_outputs(db.at("pipeline/record")));
  }
  for (const std::string& must : required) {
    INFO("dataset " << must << " of " << a);
    REQUIRE(da.count(must) == 1);
  }
  std::vector<std::string> na, nb;
  for (const auto& [k, v] : da) na.push_back(k);
  for (const auto& [k, v] : db) nb.push_back(k);
  REQUIRE(na == nb);
  for (const auto& [name, x] : da) {
    if (std::find(skip.begin(), skip.end(), name) != skip.end()) continue;
    const RawDataset& y = db.at(name);
    INFO("dataset " << name << " of " << a << " vs " << b);
    CHECK(x.type == y.type);
    CHECK(x.dims == y.dims);
    REQUIRE(x.bytes.size() == y.bytes.size());
    CHECK(std::memcmp(x.bytes.data(), y.bytes.data(), x.bytes.size()) == 0);
  }
}

/// Bit-for-bit comparison of two state files (checkpoint.h5 / final_state.h5); the core state
/// datasets must be present.
inline void require_identical_state(const std::filesystem::path& a, const std::filesystem::path& b,
                                    const std::vector<std::string>& skip = {}) {
  require_identical_files(a, b,
                          {"state/particles/position", "state/particles/velocity", "state/particles/omega", "state/particles/orientation",
                           "state/particles/force", "state/contacts/state", "state/contacts/id_i", "state/step", "state/rng"},
                          skip);
}

}  // namespace sparkdem::test
