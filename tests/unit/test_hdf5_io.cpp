/// Tests of the HDF5 layer: H5File, the checkpoint Hdf5Archive and the ResultsWriter.
#include <catch2/catch.hpp>
#include <hdf5.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "io/hdf5/h5file.hpp"
#include "io/hdf5/results_writer.hpp"
#include "io/restart/hdf5_archive.hpp"

namespace test_hdf5_io {

namespace fs = std::filesystem;
using sparkdem::Quat;
using sparkdem::SetupError;
using sparkdem::Vec3;
using sparkdem::io::ContactFrame;
using sparkdem::io::FrameField;
using sparkdem::io::H5File;
using sparkdem::io::Hdf5Archive;
using sparkdem::io::ResultsWriter;

namespace {

/// A fresh, uniquely named directory under the system temp directory, removed at scope exit.
struct TempDir {
  fs::path path;
  TempDir() {
    static std::atomic<int> counter{0};
    const auto stamp = std::chrono::steady_clock::now().time_since_epoch().count();
    path = fs::temp_directory_path() / ("sparkdem_h5_" + std::to_string(stamp) + "_" + std::to_string(counter++));
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

std::uint64_t bits(double x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

double from_bits(std::uint64_t b) {
  double x;
  std::memcpy(&x, &b, sizeof x);
  return x;
}

/// Values whose exact bits matter: signed zero, NaN with payload, infinities, subnormals.
std::vector<double> tricky_doubles() {
  return {0.0,
          -0.0,
          1.0 / 3.0,
          -2.5e-300,
          std::numeric_limits<double>::denorm_min(),
          std::numeric_limits<double>::max(),
          std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity(),
          from_bits(0x7ff8dead0000beefULL),
          0.1 + 0.2,
          std::nextafter(1.0, 2.0),
          -1e-17};
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (bits(a[i]) != bits(b[i])) return false;
  return true;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::size_t count(const std::string& haystack, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t pos = haystack.find(needle); pos != std::string::npos; pos = haystack.find(needle, pos + 1)) ++n;
  return n;
}

}  // namespace

TEST_CASE("H5File writes and reads datasets, attributes and groups", "[io][hdf5]") {
  TempDir dir;
  const fs::path file = dir.path / "a.h5";
  {
    H5File f = H5File::create(file);
    f.write("/g/d2", std::vector<double>{1, 2, 3, 4, 5, 6}, 3);
    f.write("g/d1", std::vector<double>{7, 8});
    f.write("/ints", std::vector<std::int64_t>{-1, std::numeric_limits<std::int64_t>::max(), 3, 4}, 2);
    f.write("/empty2", std::vector<double>{}, 4);
    f.write("/empty1", std::vector<std::int64_t>{});
    f.write_string("/s", "hello");
    f.create_group("/a/b/c");
    f.create_group("/a/b");  // existing: no-op
    f.set_attribute("/g/d2", "unit", std::string("m"));
    f.set_attribute("/g", "x", 2.5);
    f.set_attribute("/g", "n", std::int64_t{42});
    f.set_attribute("/g", "n", std::int64_t{43});  // replaces
    f.set_attribute("/", "empty", std::string());
    CHECK_THROWS_AS(f.write("/g/d1", std::vector<double>{1}), SetupError);          // exists
    CHECK_THROWS_AS(f.write("/bad", std::vector<double>{1, 2, 3}, 2), SetupError);  // not a multiple
    CHECK_THROWS_AS(f.set_attribute("/nope", "x", 1.0), SetupError);
    f.close();
    CHECK_FALSE(f.is_open());
    CHECK_THROWS_AS(f.exists("/g"), SetupError);
  }
  const H5File f = H5File::open_read(file);
  CHECK(f.exists("/g/d2"));
  CHECK(f.exists("g"));
  CHECK(f.exists("/"));
  CHECK_FALSE(f.exists("/g/nope"));
  CHECK_FALSE(f.exists("/nope/deeper"));
  CHECK_FALSE(f.exists("/g/d1/below_a_dataset"));
  CHECK(f.shape("/g/d2") == std::vector<std::size_t>{2, 3});
  CHECK(f.shape("/g/d1") == std::vector<std::size_t>{2});
  CHECK(f.read_doubles("/g/d2") == std::vector<double>{1, 2, 3, 4, 5, 6});
  CHECK(f.read_doubles("/g/d1") == std::vector<double>{7, 8});
  CHECK(f.read_int64s("/ints") == std::vector<std::int64_t>{-1, std::numeric_limits<std::int64_t>::max(), 3, 4});
  CHECK(f.shape("/empty2") == std::vector<std::size_t>{0, 4});
  CHECK(f.read_doubles("/empty2").empty());
  CHECK(f.shape("/empty1") == std::vector<std::size_t>{0});
  CHECK(f.read_int64s("/empty1").empty());
  CHECK(f.read_string("/s") == "hello");
  CHECK(f.children("/") == std::vector<std::string>{"a", "empty1", "empty2", "g", "ints", "s"});
  CHECK(f.children("/a/b") == std::vector<std::string>{"c"});
  CHECK(f.attribute_string("/g/d2", "unit") == "m");
  CHECK(f.attribute_double("/g", "x") == 2.5);
  CHECK(f.attribute_int64("/g", "n") == 43);
  CHECK(f.attribute_string("/", "empty").empty());
  CHECK(f.has_attribute("/g", "x"));
  CHECK_FALSE(f.has_attribute("/g", "y"));
  CHECK_THROWS_AS(f.attribute_double("/g", "y"), SetupError);
  CHECK_THROWS_AS(f.read_doubles("/ints"), SetupError);  // wrong type class
  CHECK_THROWS_AS(f.read_int64s("/g/d1"), SetupError);
  CHECK_THROWS_AS(f.read_double("/g/d1"), SetupError);  // two values, not one
  CHECK_THROWS_AS(f.children("/missing"), SetupError);
}

TEST_CASE("H5File errors name the file and the object", "[io][hdf5]") {
  TempDir dir;
  const fs::path missing = dir.path / "missing.h5";
  try {
    (void)H5File::open_read(missing);
    FAIL("expected SetupError");
  } catch (const SetupError& e) { CHECK_THAT(e.what(), Catch::Contains(missing.string())); }
  const fs::path text = dir.path / "not_hdf5.h5";
  std::ofstream(text) << "not an HDF5 file\n";
  CHECK_THROWS_AS(H5File::open_read(text), SetupError);
  CHECK_THROWS_AS(H5File::create(dir.path / "no_such_dir" / "x.h5"), SetupError);

  const fs::path file = dir.path / "b.h5";
  H5File::create(file).write("/x", std::vector<double>{1});
  const H5File f = H5File::open_read(file);
  try {
    (void)f.read_doubles("/group/missing");
    FAIL("expected SetupError");
  } catch (const SetupError& e) { CHECK_THAT(e.what(), Catch::Contains(file.string()) && Catch::Contains("/group/missing")); }
}

TEST_CASE("Hdf5Archive round-trips every item bit for bit", "[io][hdf5][restart]") {
  TempDir dir;
  const fs::path path = dir.path / "checkpoint.h5";

  std::vector<double> doubles = tricky_doubles();
  std::vector<double> rows3 = tricky_doubles();  // 12 values = 4 rows of 3
  std::vector<double> no_doubles;
  std::vector<std::int64_t> ints{std::numeric_limits<std::int64_t>::min(), -1, 0, 1, std::numeric_limits<std::int64_t>::max(), 7};
  std::vector<std::int64_t> no_ints;
  double scalar = from_bits(0xfff0000000000123ULL);  // a negative NaN with payload
  double zero = -0.0;
  std::int64_t count_in = std::numeric_limits<std::int64_t>::min();
  std::string text = "mt19937 state\n1 2 3\r\n\ttab \"quoted\" <xml> & \xc3\xa9";
  std::string empty_text;
  std::string with_nuls("a\0b\0\0", 5);
  std::string big(1 << 20, '\0');
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<char>((i * 2654435761u) >> 13);
  big += "\n\n";
  std::vector<Vec3> vecs{Vec3(1.0 / 3.0, -0.0, 1e300), Vec3(std::nextafter(0.0, 1.0), 2, 3)};
  std::vector<Vec3> no_vecs;
  std::vector<Quat> quats{Quat(0.5, -0.5, 0.5, -0.5), Quat(std::sqrt(0.5), 0, std::sqrt(0.5), 0)};
  std::vector<std::int32_t> int32s{-5, 0, std::numeric_limits<std::int32_t>::max()};
  bool flag_true = true;
  bool flag_false = false;

  {
    Hdf5Archive out = Hdf5Archive::for_writing(path);
    CHECK_FALSE(out.reading());
    out.visit("particles/doubles", doubles);
    out.visit("particles/rows3", rows3, 3);
    out.visit("particles/none", no_doubles, 3);
    out.visit("ints", ints, 2);
    out.visit("no_ints", no_ints);
    out.visit("scalars/nan", scalar);
    out.visit("scalars/negzero", zero);
    out.visit("scalars/count", count_in);
    out.visit("strings/text", text);
    out.visit("strings/empty", empty_text);
    out.visit("strings/nuls", with_nuls);
    out.visit("strings/big", big);
    out.visit("eigen/vecs", vecs);
    out.visit("eigen/no_vecs", no_vecs);
    out.visit("eigen/quats", quats);
    out.visit("int32s", int32s);
    out.visit("flags/t", flag_true);
    out.visit("flags/f", flag_false);
    CHECK(out.has("particles/doubles"));
    CHECK_FALSE(out.has("particles/missing"));
    CHECK_THROWS_AS(out.visit("particles/doubles", doubles), SetupError);  // written twice
    std::vector<double> ragged{1, 2, 3, 4};
    CHECK_THROWS_AS(out.visit("ragged", ragged, 3), SetupError);
    out.commit();
    CHECK_THROWS_AS(out.visit("late", scalar), SetupError);
  }

  Hdf5Archive in = Hdf5Archive::for_reading(path);
  CHECK(in.reading());
  CHECK(in.has("particles/rows3"));
  CHECK(in.has("strings"));
  CHECK_FALSE(in.has("optional/item"));

  std::vector<double> d, r3, nd;
  std::vector<std::int64_t> i, ni;
  double s = 0, z = 1;
  std::int64_t c = 0;
  std::string t, e = "not empty", nul, b;
  std::vector<Vec3> v, nv{Vec3::Ones()};
  std::vector<Quat> q;
  std::vector<std::int32_t> i32;
  bool ft = false, ff = true;
  in.visit("particles/doubles", d);
  in.visit("particles/rows3", r3, 3);
  in.visit("particles/none", nd, 3);
  in.visit("ints", i, 2);
  in.visit("no_ints", ni);
  in.visit("scalars/nan", s);
  in.visit("scalars/negzero", z);
  in.visit("scalars/count", c);
  in.visit("strings/text", t);
  in.visit("strings/empty", e);
  in.visit("strings/nuls", nul);
  in.visit("strings/big", b);
  in.visit("eigen/vecs", v);
  in.visit("eigen/no_vecs", nv);
  in.visit("eigen/quats", q);
  in.visit("int32s", i32);
  in.visit("flags/t", ft);
  in.visit("flags/f", ff);

  CHECK(same_bits(d, doubles));
  CHECK(same_bits(r3, rows3));
  CHECK(nd.empty());
  CHECK(i == ints);
  CHECK(ni.empty());
  CHECK(bits(s) == bits(scalar));
  CHECK(bits(z) == bits(-0.0));
  CHECK(c == count_in);
  CHECK(t == text);
  CHECK(e.empty());
  CHECK(nul == with_nuls);
  CHECK(b.size() == big.size());
  CHECK(b == big);
  REQUIRE(v.size() == vecs.size());
  for (std::size_t k = 0; k < v.size(); ++k)
    for (int j = 0; j < 3; ++j) CHECK(bits(v[k][j]) == bits(vecs[k][j]));
  CHECK(nv.empty());
  REQUIRE(q.size() == quats.size());
  for (std::size_t k = 0; k < q.size(); ++k) CHECK(q[k].coeffs() == quats[k].coeffs());
  CHECK(i32 == int32s);
  CHECK(ft);
  CHECK_FALSE(ff);

  // Shape and type mismatches are reported, not silently converted.
  std::vector<double> wrong;
  CHECK_THROWS_AS(in.visit("particles/rows3", wrong, 4), SetupError);
  CHECK_THROWS_AS(in.visit("particles/rows3", wrong), SetupError);
  std::vector<std::int64_t> wrong_type;
  CHECK_THROWS_AS(in.visit("particles/doubles", wrong_type), SetupError);
  std::string not_a_string;
  CHECK_THROWS_AS(in.visit("scalars/count", not_a_string), SetupError);
}

TEST_CASE("Hdf5Archive reading a missing item names the item and the file", "[io][hdf5][restart]") {
  TempDir dir;
  const fs::path path = dir.path / "ck.h5";
  {
    Hdf5Archive out = Hdf5Archive::for_writing(path);
    double x = 1.0;
    out.visit("present", x);
    out.commit();
  }
  Hdf5Archive in = Hdf5Archive::for_reading(path);
  std::vector<double> v;
  try {
    in.visit("particles/velocity", v, 3);
    FAIL("expected SetupError");
  } catch (const SetupError& e) { CHECK_THAT(e.what(), Catch::Contains("particles/velocity") && Catch::Contains(path.string())); }
  double x = 0;
  CHECK_THROWS_AS(in.visit("absent", x), SetupError);
  std::string s;
  CHECK_THROWS_AS(in.visit("absent", s), SetupError);
  CHECK_THROWS_AS(in.commit(), SetupError);
  CHECK_THROWS_AS(Hdf5Archive::for_reading(dir.path / "nope.h5"), SetupError);
}

TEST_CASE("Hdf5Archive writes through a tmp file renamed on commit", "[io][hdf5][restart]") {
  TempDir dir;
  const fs::path path = dir.path / "ck.h5";
  const fs::path tmp = dir.path / "ck.h5.tmp";

  SECTION("no final file before commit, tmp renamed by commit") {
    Hdf5Archive out = Hdf5Archive::for_writing(path);
    double x = 3.0;
    out.visit("x", x);
    CHECK(fs::exists(tmp));
    CHECK_FALSE(fs::exists(path));
    out.commit();
    CHECK(fs::exists(path));
    CHECK_FALSE(fs::exists(tmp));
    CHECK_THROWS_AS(out.commit(), SetupError);
  }
  SECTION("uncommitted archive removes its tmp file and keeps the old checkpoint") {
    {
      Hdf5Archive old = Hdf5Archive::for_writing(path);
      std::int64_t generation = 1;
      old.visit("generation", generation);
      old.commit();
    }
    {
      Hdf5Archive out = Hdf5Archive::for_writing(path);
      std::int64_t generation = 2;
      out.visit("generation", generation);
      CHECK(fs::exists(tmp));
      // destroyed without commit, as after an exception
    }
    CHECK_FALSE(fs::exists(tmp));
    Hdf5Archive in = Hdf5Archive::for_reading(path);
    std::int64_t generation = 0;
    in.visit("generation", generation);
    CHECK(generation == 1);
  }
  SECTION("a moved archive commits once and cleans up once") {
    Hdf5Archive first = Hdf5Archive::for_writing(path);
    Hdf5Archive second(std::move(first));
    double x = 1.0;
    second.visit("x", x);
    second.commit();
    CHECK(fs::exists(path));
  }
}

namespace {

/// Particle fields of a frame with n particles, values depending on the frame number.
std::vector<FrameField> particle_fields(int frame, int n) {
  FrameField position{"position", 3, {}, "m"};
  FrameField radius{"radius", 1, {}, "m"};
  FrameField velocity{"velocity", 3, {}, "m/s"};
  FrameField stress{"stress", 6, {}, "Pa"};
  FrameField quaternion{"orientation", 4, {}, ""};
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) position.data.push_back(frame + i + k / 10.0 + 1.0 / 3.0);
    radius.data.push_back(0.001 * (i + 1));
    for (int k = 0; k < 3; ++k) velocity.data.push_back(-frame * 0.1 - k);
    for (int k = 0; k < 6; ++k) stress.data.push_back(1e5 * k + i);
    for (int k = 0; k < 4; ++k) quaternion.data.push_back(k == 0 ? 1.0 : 0.0);
  }
  return {position, radius, velocity, stress, quaternion};
}

ContactFrame contact_frame(int frame, int m) {
  ContactFrame c;
  FrameField force{"force", 3, {}, "N"};
  FrameField overlap{"overlap", 1, {}, "m"};
  for (int k = 0; k < m; ++k) {
    c.pairs.push_back(k);
    c.pairs.push_back(k + 1 + frame);
    for (int j = 0; j < 3; ++j) force.data.push_back(frame * 10.0 + k + j * 0.25);
    overlap.data.push_back(1e-6 * (k + 1));
  }
  c.fields = {force, overlap};
  return c;
}

}  // namespace

TEST_CASE("ResultsWriter writes frame files, results.h5 linking them, time series, XDMF and CSV", "[io][hdf5][results]") {
  TempDir dir;
  const fs::path outdir = dir.path / "out";  // created by the writer
  const std::vector<std::string> columns{"time", "kinetic_energy", "step"};
  const std::vector<std::vector<double>> rows{{0.0, 1.0 / 3.0, 0}, {1e-3, 2.5e-17, 10}, {2e-3, -0.0, 20}};
  const std::vector<int> particles{4, 0, 3};  // frame 1 has no particles and no contacts
  const std::vector<int> contacts{2, 0, 5};
  {
    ResultsWriter w(outdir);
    for (int f = 0; f < 3; ++f) {
      char file[32];
      std::snprintf(file, sizeof file, "frames/frame_%06d.h5", f);
      // write_frame returns only once the frame file is complete under its final name.
      CHECK(w.write_frame(10 * f, 1e-3 * f, f < 2 ? "settle" : "shear", particle_fields(f, particles[f]), contact_frame(f, contacts[f])) ==
            file);
      CHECK(w.frames() == f + 1);
      CHECK(fs::exists(outdir / file));
      CHECK_FALSE(fs::exists(outdir / (std::string(file) + ".tmp")));
      CHECK(H5File::open_read(outdir / file).attribute_int64("/", "step") == 10 * f);
    }
    w.set_timeseries(columns, rows);
    CHECK_FALSE(fs::exists(outdir / "results.h5"));  // the index is written by write_index/finalize
    w.finalize();
    CHECK_THROWS_AS(w.write_frame(0, 0, "x", particle_fields(0, 1), {}), SetupError);
    CHECK_THROWS_AS(w.write_index(), SetupError);
  }
  CHECK(fs::exists(outdir / "results.h5"));
  CHECK(fs::exists(outdir / "results.xdmf"));
  CHECK(fs::exists(outdir / "timeseries.csv"));
  for (const auto& entry : fs::recursive_directory_iterator(outdir)) CHECK(entry.path().extension() != ".tmp");

  // The layout is read through results.h5 (external links into frames/), from another working
  // directory: the links resolve relative to results.h5.
  const fs::path cwd = fs::current_path();
  fs::current_path(fs::temp_directory_path());
  const H5File h5 = H5File::open_read(outdir / "results.h5");
  fs::current_path(cwd);
  CHECK(h5.children("/frames") == std::vector<std::string>{"000000", "000001", "000002"});
  for (int f = 0; f < 3; ++f) {
    char name[16];
    std::snprintf(name, sizeof name, "/frames/%06d", f);
    const std::string g = name;
    CHECK(h5.attribute_int64(g, "step") == 10 * f);
    CHECK(h5.attribute_double(g, "time") == 1e-3 * f);
    CHECK(h5.attribute_string(g, "stage") == (f < 2 ? "settle" : "shear"));
    for (const FrameField& field : particle_fields(f, particles[f])) {
      const std::string p = g + "/particles/" + field.name;
      CHECK(h5.shape(p) == std::vector<std::size_t>{static_cast<std::size_t>(particles[f]), static_cast<std::size_t>(field.components)});
      CHECK(same_bits(h5.read_doubles(p), field.data));
      CHECK(h5.attribute_string(p, "unit") == field.unit);
    }
    const ContactFrame c = contact_frame(f, contacts[f]);
    CHECK(h5.shape(g + "/contacts/pairs") == std::vector<std::size_t>{static_cast<std::size_t>(contacts[f]), 2});
    CHECK(h5.read_int64s(g + "/contacts/pairs") == c.pairs);
    for (const FrameField& field : c.fields) {
      const std::string p = g + "/contacts/" + field.name;
      CHECK(h5.shape(p) == std::vector<std::size_t>{static_cast<std::size_t>(contacts[f]), static_cast<std::size_t>(field.components)});
      CHECK(same_bits(h5.read_doubles(p), field.data));
      CHECK(h5.attribute_string(p, "unit") == field.unit);
    }
  }
  for (std::size_t k = 0; k < columns.size(); ++k) {
    std::vector<double> expected;
    for (const auto& row : rows) expected.push_back(row[k]);
    CHECK(same_bits(h5.read_doubles("/timeseries/" + columns[k]), expected));
  }

  const std::string xdmf = read_text(outdir / "results.xdmf");
  CHECK(xdmf.rfind("<?xml", 0) == 0);
  CHECK_THAT(xdmf, Catch::Contains("CollectionType=\"Temporal\"") && Catch::Contains("</Xdmf>"));
  CHECK(count(xdmf, "GridType=\"Uniform\"") == 3);
  CHECK(count(xdmf, "TopologyType=\"Polyvertex\"") == 3);
  CHECK(count(xdmf, "<Grid") == count(xdmf, "</Grid>"));
  CHECK(count(xdmf, "<Attribute") == count(xdmf, "</Attribute>"));
  CHECK(count(xdmf, "<DataItem") == count(xdmf, "</DataItem>"));
  CHECK_THAT(xdmf, Catch::Contains("<Time Value=\"0.002\"/>"));
  CHECK_THAT(xdmf, Catch::Contains("NumberOfElements=\"4\""));
  for (int f = 0; f < 3; ++f) {
    char name[16];
    std::snprintf(name, sizeof name, "%06d", f);
    const std::string g = std::string("frames/frame_") + name + ".h5:/particles/";
    CHECK_THAT(xdmf, Catch::Contains("<Geometry GeometryType=\"XYZ\">") && Catch::Contains(g + "position<"));
    for (const char* field : {"radius", "velocity", "stress", "orientation"}) CHECK_THAT(xdmf, Catch::Contains(g + field + "<"));
  }
  CHECK_THAT(xdmf, Catch::Contains("<Attribute Name=\"radius\" AttributeType=\"Scalar\" Center=\"Node\">"));
  CHECK_THAT(xdmf, Catch::Contains("<Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">"));
  CHECK_THAT(xdmf, Catch::Contains("<Attribute Name=\"stress\" AttributeType=\"Tensor6\" Center=\"Node\">"));
  CHECK_THAT(xdmf, Catch::Contains("<Attribute Name=\"orientation\" AttributeType=\"Matrix\" Center=\"Node\">"));
  CHECK(count(xdmf, "<Attribute Name=\"position\"") == 0);

  std::ifstream csv(outdir / "timeseries.csv");
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(csv, line)) lines.push_back(line);
  REQUIRE(lines.size() == rows.size() + 1);
  CHECK(lines[0] == "time,kinetic_energy,step");
  CHECK(lines[1] == "0,0.33333333333333331,0");
  for (std::size_t r = 0; r < rows.size(); ++r) {
    std::istringstream fields(lines[r + 1]);
    std::string cell;
    for (std::size_t k = 0; k < columns.size(); ++k) {
      REQUIRE(std::getline(fields, cell, ','));
      CHECK(bits(std::stod(cell)) == bits(rows[r][k]));
    }
  }
}

TEST_CASE("ResultsWriter not finalized keeps its complete frames and leaves no tmp files", "[io][hdf5][results]") {
  TempDir dir;
  {
    ResultsWriter w(dir.path);
    w.write_frame(0, 0.0, "s", particle_fields(0, 2), contact_frame(0, 1));
    w.write_frame(5, 1e-4, "s", particle_fields(1, 2), contact_frame(1, 3));
    w.set_timeseries({"time"}, {{0.0}});
  }
  CHECK_FALSE(fs::exists(dir.path / "results.h5"));
  CHECK_FALSE(fs::exists(dir.path / "results.xdmf"));
  CHECK_FALSE(fs::exists(dir.path / "timeseries.csv"));
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir.path)) names.push_back(fs::relative(entry.path(), dir.path).string());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"frames", "frames/frame_000000.h5", "frames/frame_000001.h5"});
  // The frames are complete: every dataset with its data.
  const H5File f1 = H5File::open_read(dir.path / "frames/frame_000001.h5");
  CHECK(f1.attribute_int64("/", "step") == 5);
  CHECK(f1.attribute_double("/", "time") == 1e-4);
  CHECK(f1.attribute_string("/", "stage") == "s");
  for (const FrameField& field : particle_fields(1, 2)) CHECK(same_bits(f1.read_doubles("/particles/" + field.name), field.data));
  CHECK(f1.read_int64s("/contacts/pairs") == contact_frame(1, 3).pairs);
  CHECK(same_bits(f1.read_doubles("/contacts/force"), contact_frame(1, 3).fields[0].data));
}

TEST_CASE("ResultsWriter writes a made field as the same field held in data, and refuses one of the wrong size", "[io][hdf5][results]") {
  TempDir dir;
  ResultsWriter w(dir.path);
  const ContactFrame held = contact_frame(1, 3);
  ContactFrame made = held;
  int calls = 0;
  for (FrameField& f : made.fields) {
    f.rows = f.data.size() / static_cast<std::size_t>(f.components);
    f.make = [&calls, v = f.data] {
      ++calls;
      return v;
    };
    f.data.clear();
  }
  w.write_frame(0, 0.0, "s", particle_fields(0, 2), held);
  w.write_frame(1, 1e-4, "s", particle_fields(0, 2), made);
  CHECK(calls == 2);  // each made field once, when written
  const H5File a = H5File::open_read(dir.path / "frames/frame_000000.h5"), b = H5File::open_read(dir.path / "frames/frame_000001.h5");
  for (const FrameField& f : held.fields) {
    CHECK(same_bits(b.read_doubles("/contacts/" + f.name), f.data));
    CHECK(b.shape("/contacts/" + f.name) == a.shape("/contacts/" + f.name));
  }
  made.fields[0].rows = 2;  // claims 2 rows, makes 3: the frame is refused
  CHECK_THROWS_AS(w.write_frame(2, 2e-4, "s", particle_fields(0, 2), made), SetupError);
  CHECK_FALSE(fs::exists(dir.path / "frames/frame_000002.h5"));
}

TEST_CASE("ResultsWriter::write_index publishes the frames so far, and a new writer takes the directory over", "[io][hdf5][results]") {
  TempDir dir;
  {
    ResultsWriter w(dir.path);
    w.write_frame(0, 0.0, "s", particle_fields(0, 2), contact_frame(0, 1));
    w.write_frame(1, 1e-3, "s", particle_fields(1, 3), contact_frame(1, 2));
    w.set_timeseries({"time", "step"}, {{0.0, 0.0}, {1e-3, 1.0}});
    w.write_index();
    w.write_frame(2, 2e-3, "s", particle_fields(2, 4), {});
    // The index still describes the state of the last write_index().
    const H5File h5 = H5File::open_read(dir.path / "results.h5");
    CHECK(h5.children("/frames") == std::vector<std::string>{"000000", "000001"});
    CHECK(h5.shape("/frames/000001/particles/position") == std::vector<std::size_t>{3, 3});
    CHECK(h5.read_doubles("/timeseries/step") == std::vector<double>{0.0, 1.0});
    CHECK(count(read_text(dir.path / "results.xdmf"), "GridType=\"Uniform\"") == 2);
    CHECK(read_text(dir.path / "timeseries.csv") == "time,step\n0,0\n0.001,1\n");
    CHECK(fs::exists(dir.path / "frames/frame_000002.h5"));
  }
  // Files of other kinds in the directory are left alone.
  std::ofstream(dir.path / "checkpoint.h5") << "keep";
  std::ofstream(dir.path / "frames" / "notes.txt") << "keep";
  std::ofstream(dir.path / "frames" / "frame_000007.h5.tmp") << "stale";
  {
    ResultsWriter w(dir.path);
    CHECK_FALSE(fs::exists(dir.path / "results.h5"));
    CHECK_FALSE(fs::exists(dir.path / "results.xdmf"));
    CHECK_FALSE(fs::exists(dir.path / "timeseries.csv"));
    std::vector<std::string> left;
    for (const auto& entry : fs::directory_iterator(dir.path / "frames")) left.push_back(entry.path().filename().string());
    CHECK(left == std::vector<std::string>{"notes.txt"});
    CHECK(read_text(dir.path / "checkpoint.h5") == "keep");
    w.write_frame(9, 0.5, "t", particle_fields(3, 1), {});
    w.finalize();
  }
  const H5File h5 = H5File::open_read(dir.path / "results.h5");
  CHECK(h5.children("/frames") == std::vector<std::string>{"000000"});
  CHECK(h5.attribute_int64("/frames/000000", "step") == 9);
}

TEST_CASE("ResultsWriter rejects inconsistent frames without writing them", "[io][hdf5][results]") {
  TempDir dir;
  ResultsWriter w(dir.path);
  std::vector<FrameField> no_position{{"radius", 1, {1.0}, "m"}};
  CHECK_THROWS_AS(w.write_frame(0, 0, "s", no_position, {}), SetupError);
  std::vector<FrameField> bad_rows = particle_fields(0, 2);
  bad_rows[1].data.push_back(1.0);  // radius has 3 rows, position 2
  CHECK_THROWS_AS(w.write_frame(0, 0, "s", bad_rows, {}), SetupError);
  ContactFrame odd;
  odd.pairs = {1, 2, 3};
  CHECK_THROWS_AS(w.write_frame(0, 0, "s", particle_fields(0, 2), odd), SetupError);
  ContactFrame short_field = contact_frame(0, 2);
  short_field.fields[0].data.resize(3);
  CHECK_THROWS_AS(w.write_frame(0, 0, "s", particle_fields(0, 2), short_field), SetupError);
  CHECK(w.frames() == 0);
  CHECK_THROWS_AS(w.set_timeseries({"a", "b"}, {{1.0}}), SetupError);
  CHECK_THROWS_AS(w.set_timeseries({"a,b"}, {}), SetupError);
  CHECK_THROWS_AS(w.set_timeseries({"a", "a"}, {}), SetupError);
  w.write_frame(0, 0, "s", particle_fields(0, 2), {});  // the file is still usable
  CHECK(w.frames() == 1);
  w.finalize();
  const H5File h5 = H5File::open_read(dir.path / "results.h5");
  CHECK(h5.children("/frames") == std::vector<std::string>{"000000"});
  CHECK(h5.children("/timeseries").empty());
  std::vector<std::string> frame_files;
  for (const auto& entry : fs::directory_iterator(dir.path / "frames")) frame_files.push_back(entry.path().filename().string());
  CHECK(frame_files == std::vector<std::string>{"frame_000000.h5"});  // the rejected frames left no file
  CHECK(h5.shape("/frames/000000/contacts/pairs") == std::vector<std::size_t>{0, 2});
}

TEST_CASE("HDF5 identifiers are all released, also on error paths", "[io][hdf5]") {
  TempDir dir;
  {
    ResultsWriter w(dir.path / "out");
    w.write_frame(0, 0.0, "s", particle_fields(0, 3), contact_frame(0, 2));
    CHECK_THROWS_AS(w.write_frame(1, 0.0, "s", {}, {}), SetupError);
    w.set_timeseries({"time"}, {{0.0}});
    w.finalize();
    ResultsWriter unfinished(dir.path / "unfinished");
    unfinished.write_frame(0, 0.0, "s", particle_fields(0, 1), {});
  }
  {
    Hdf5Archive out = Hdf5Archive::for_writing(dir.path / "ck.h5");
    std::string s = "state";
    std::vector<double> v{1, 2, 3};
    out.visit("s", s);
    out.visit("v", v, 3);
    out.commit();
    Hdf5Archive in = Hdf5Archive::for_reading(dir.path / "ck.h5");
    std::vector<std::int64_t> wrong;
    CHECK_THROWS_AS(in.visit("v", wrong, 3), SetupError);
    CHECK_THROWS_AS(in.visit("s", v), SetupError);
    CHECK_THROWS_AS(in.visit("missing", s), SetupError);
    in.visit("s", s);
    const H5File h5 = H5File::open_read(dir.path / "out" / "results.h5");
    CHECK_THROWS_AS(h5.attribute_int64("/frames/000000", "time"), SetupError);
    CHECK_THROWS_AS(h5.read_string("/frames/000000/particles/radius"), SetupError);
  }
  CHECK(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) == 0);
}

TEST_CASE("results.xdmf times: strictly increasing, at least 1e-15 s apart, true times where they already are",
          "[io][hdf5][results][xdmf]") {
  const double gap = ResultsWriter::kXdmfTimeGap;
  CHECK(gap > 4.0 * std::numeric_limits<double>::epsilon());  // ParaView merges grids within DBL_EPSILON s
  const double big = 1e4, up = std::nextafter(big, 2 * big);  // at 1e4 s one ulp (1.8e-12 s) exceeds the gap
  const std::vector<double> times{0.0, 0.0, 0.0, 2e-3, 2e-3, 2e-3 + 1e-16, 3e-3, big, big, up};
  const std::vector<double> listed = ResultsWriter::listed_times(times);
  REQUIRE(listed.size() == times.size());
  // (Sums rounded to the double spacing: 4.3e-19 s at 2e-3 s; tolerance 1e-18 s.)
  const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-18; };
  CHECK(listed[0] == 0.0);
  CHECK(near(listed[1], gap));  // coincident: one gap after the previous listed time
  CHECK(near(listed[2], 2 * gap));
  CHECK(listed[3] == 2e-3);  // far enough: its true time
  CHECK(near(listed[4], 2e-3 + gap));
  CHECK(near(listed[5], 2e-3 + 2 * gap));  // 1e-16 s after a frame: pushed to a gap after the listed one
  CHECK(listed[6] == 3e-3);
  CHECK(listed[7] == big);
  CHECK(listed[8] == up);                           // 1e4 + 1e-15 rounds to 1e4: one ulp instead
  CHECK(listed[9] == std::nextafter(up, 2 * big));  // its true time `up` is taken: one ulp more
  for (std::size_t k = 1; k < listed.size(); ++k) CHECK(listed[k] - listed[k - 1] >= gap - 1e-18);
  CHECK(ResultsWriter::listed_times({}).empty());
}

}  // namespace test_hdf5_io
