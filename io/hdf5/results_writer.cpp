#include "io/hdf5/results_writer.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstring>
#include <limits>
#include <regex>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include "engine/core/error.hpp"
#include "io/files/durable_file.hpp"
#include "io/hdf5/h5file.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

constexpr const char* kResults = "results.h5";
constexpr const char* kXdmf = "results.xdmf";
constexpr const char* kCsv = "timeseries.csv";
constexpr const char* kFrames = "frames";

/// Full-precision text of a double (round-trips exactly).
std::string number(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

std::string xml_escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

/// XDMF attribute type for a field with this many components.
const char* attribute_type(int components) {
  switch (components) {
    case 1:
      return "Scalar";
    case 3:
      return "Vector";
    case 6:
      return "Tensor6";
    case 9:
      return "Tensor";
    default:
      return "Matrix";
  }
}

/// A name usable as an HDF5 link name (and a CSV column when `csv`).
bool valid_name(const std::string& name, bool csv) {
  if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos) return false;
  return !csv || name.find_first_of(",\"\r\n") == std::string::npos;
}

/// "000003" for frame 3: the frame's name in results.h5 and in its file name.
std::string counter(int index) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "%06d", index);
  return buffer;
}

/// Creates `outdir/frames` and removes an earlier run's results from `outdir`.
void take_over(const fs::path& outdir) {
  std::error_code ec;
  fs::create_directories(outdir / kFrames, ec);
  if (ec) throw SetupError("results directory '" + outdir.string() + "': cannot create it: " + ec.message());
  for (const char* name : {kXdmf, kResults, kCsv}) {  // the index first: it refers to the frames
    remove_if_present(outdir / name);
    remove_if_present(tmp_name(outdir / name));
  }
  static const std::regex frame_name(R"(frame_[0-9]{6,}\.h5(\.tmp)?)");
  for (const auto& entry : fs::directory_iterator(outdir / kFrames, ec))
    if (std::regex_match(entry.path().filename().string(), frame_name)) remove_if_present(entry.path());
  if (ec) throw SetupError("results directory '" + (outdir / kFrames).string() + "': cannot list it: " + ec.message());
}

/// Removes a tmp file when a write fails half way (unless dismissed after the commit).
struct TmpGuard {
  fs::path file;
  bool armed = true;
  ~TmpGuard() {
    if (!armed) return;
    std::error_code ec;
    fs::remove(file, ec);
  }
};

}  // namespace

ResultsWriter::ResultsWriter(fs::path outdir) : outdir_(std::move(outdir)) { take_over(outdir_); }

ResultsWriter::~ResultsWriter() {
  std::error_code ec;
  for (const char* name : {kResults, kXdmf, kCsv}) fs::remove(tmp_name(outdir_ / name), ec);
  fs::remove(tmp_name(outdir_ / frame_file(frames())), ec);
}

std::string ResultsWriter::frame_file(int index) { return std::string(kFrames) + "/frame_" + counter(index) + ".h5"; }

void ResultsWriter::fail(const std::string& what) const { throw SetupError("results in '" + outdir_.string() + "': " + what); }

std::string ResultsWriter::write_frame(std::int64_t step, double time, const std::string& stage,
                                       const std::vector<FrameField>& particle_fields, const ContactFrame& contacts,
                                       const std::vector<std::pair<std::string, ContactFrame>>& networks) {
  if (finalized_) fail("write_frame() called after finalize()");
  const std::string name = "frame " + counter(frames());

  // Validate everything before writing anything, so a bad frame leaves no file.
  const auto check_fields = [&](const std::vector<FrameField>& fields, const std::string& kind, std::size_t expected_rows) {
    std::set<std::string> seen;
    for (const FrameField& f : fields) {
      const std::string label = kind + " field '" + f.name + "' of " + name;
      if (!valid_name(f.name, false)) fail(label + ": the name is empty or contains '/'");
      if (kind == "contact" && f.name == "pairs") fail(label + ": the name 'pairs' is reserved");
      if (!seen.insert(f.name).second) fail(label + ": duplicate field name");
      if (f.components < 1) fail(label + ": components must be at least 1");
      const auto c = static_cast<std::size_t>(f.components);
      if (f.data.size() % c != 0)
        fail(label + ": " + std::to_string(f.data.size()) + " values are not a multiple of " + std::to_string(c) + " components");
      if (f.data.size() / c != expected_rows)
        fail(label + ": " + std::to_string(f.data.size() / c) + " rows, expected " + std::to_string(expected_rows));
    }
  };
  std::size_t particles = 0;
  bool has_position = false;
  for (const FrameField& f : particle_fields) {
    if (f.name == "position") {
      if (f.components != 3) fail("field 'position' of " + name + " must have 3 components");
      has_position = true;
      particles = f.data.size() / 3;
    }
  }
  if (!has_position) fail(name + " has no particle field 'position'");
  check_fields(particle_fields, "particle", particles);
  if (contacts.pairs.size() % 2 != 0) fail("contact pairs of " + name + " hold an odd number of ids");
  check_fields(contacts.fields, "contact", contacts.pairs.size() / 2);
  std::set<std::string> network_names;
  for (const auto& [nname, net] : networks) {
    if (!valid_name(nname, false) || !network_names.insert(nname).second)
      fail("network '" + nname + "' of " + name + ": the name is empty, contains '/' or is repeated");
    if (net.pairs.size() % 2 != 0) fail("network '" + nname + "' of " + name + ": pairs hold an odd number of ids");
    check_fields(net.fields, "contact", net.pairs.size() / 2);
  }

  const std::string relative = frame_file(frames());
  const fs::path final_path = outdir_ / relative;
  TmpGuard tmp{tmp_name(final_path)};
  FrameInfo info{relative, time, step, stage, particles, {}};
  {
    H5File file = H5File::create(tmp.file);
    file.set_attribute("/", "step", step);
    file.set_attribute("/", "time", time);
    file.set_attribute("/", "stage", stage);
    file.create_group("/particles");
    for (const FrameField& f : particle_fields) {
      const std::string path = "/particles/" + f.name;
      file.write(path, f.data, f.components);
      file.set_attribute(path, "unit", f.unit);
      info.fields.emplace_back(f.name, f.components);
    }
    file.create_group("/contacts");
    file.write("/contacts/pairs", contacts.pairs, 2);
    for (const FrameField& f : contacts.fields) {
      const std::string path = "/contacts/" + f.name;
      file.write(path, f.data, f.components);
      file.set_attribute(path, "unit", f.unit);
    }
    if (!networks.empty()) file.create_group("/networks");
    for (const auto& [nname, net] : networks) {
      const std::string base = "/networks/" + nname;
      file.create_group(base);
      file.write(base + "/pairs", net.pairs, 2);
      for (const FrameField& f : net.fields) {
        file.write(base + "/" + f.name, f.data, f.components);
        file.set_attribute(base + "/" + f.name, "unit", f.unit);
      }
    }
    file.close();
  }
  commit_file(tmp.file, final_path);
  tmp.armed = false;
  frames_.push_back(std::move(info));
  index_current_ = false;
  return relative;
}

void ResultsWriter::set_timeseries(const std::vector<std::string>& columns, const std::vector<std::vector<double>>& rows) {
  if (finalized_) fail("set_timeseries() called after finalize()");
  std::set<std::string> seen;
  for (const std::string& c : columns) {
    if (!valid_name(c, true)) fail("time series column '" + c + "': the name is empty or contains '/', ',', '\"' or a newline");
    if (!seen.insert(c).second) fail("time series column '" + c + "': duplicate column name");
  }
  for (std::size_t r = 0; r < rows.size(); ++r)
    if (rows[r].size() != columns.size())
      fail("time series row " + std::to_string(r) + " has " + std::to_string(rows[r].size()) + " values, expected " +
           std::to_string(columns.size()));
  columns_ = columns;
  rows_ = rows;
  index_current_ = false;
}

void ResultsWriter::write_results_h5(const fs::path& file) const {
  H5File h5 = H5File::create(file);
  h5.create_group("/frames");
  for (std::size_t k = 0; k < frames_.size(); ++k) h5.create_external_link("/frames/" + counter(static_cast<int>(k)), frames_[k].file, "/");
  h5.create_group("/timeseries");
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    std::vector<double> column(rows_.size());
    for (std::size_t r = 0; r < rows_.size(); ++r) column[r] = rows_[r][c];
    h5.write("/timeseries/" + columns_[c], column);
  }
  h5.close();
}

void ResultsWriter::write_index() {
  if (finalized_) fail("write_index() called after finalize()");
  // All three complete and synced under tmp names, then renamed (results.xdmf, what a user
  // opens, last) and the directory synced once.
  TmpGuard csv{tmp_name(outdir_ / kCsv)}, h5{tmp_name(outdir_ / kResults)}, xdmf{tmp_name(outdir_ / kXdmf)};
  write_file_synced(csv.file, csv_text());
  write_results_h5(h5.file);
  sync_file(h5.file);
  write_file_synced(xdmf.file, xdmf_text());
  for (const auto& [tmp, name] : {std::pair{&csv, kCsv}, std::pair{&h5, kResults}, std::pair{&xdmf, kXdmf}}) {
    if (std::rename(tmp->file.c_str(), (outdir_ / name).c_str()) != 0)
      fail("cannot rename '" + tmp->file.string() + "' to '" + name + "': " + std::strerror(errno));
    tmp->armed = false;
  }
  sync_directory(outdir_);
  index_current_ = true;
}

bool ResultsWriter::finalize() {
  const bool write = !index_current_;
  if (write) write_index();
  finalized_ = true;
  return write;
}

std::vector<double> ResultsWriter::listed_times(const std::vector<double>& times) {
  std::vector<double> listed(times.size());
  for (std::size_t k = 0; k < times.size(); ++k) {
    listed[k] = times[k];
    if (k == 0) continue;
    // (x + gap rounds to x itself only where the spacing of doubles exceeds the gap.)
    const double least = std::max(listed[k - 1] + kXdmfTimeGap, std::nextafter(listed[k - 1], std::numeric_limits<double>::infinity()));
    if (!(times[k] >= least)) listed[k] = least;
  }
  return listed;
}

std::string ResultsWriter::xdmf_text() const {
  std::ostringstream out;
  const auto data_item = [&](const FrameInfo& frame, const std::string& field, int components) {
    out << "          <DataItem Dimensions=\"" << frame.particles << ' ' << components
        << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << xml_escaped(frame.file) << ":/particles/" << xml_escaped(field)
        << "</DataItem>\n";
  };
  std::vector<double> times;
  for (const FrameInfo& frame : frames_) times.push_back(frame.time);
  const std::vector<double> listed = listed_times(times);
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
      << "  <Domain>\n"
      << "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t k = 0; k < frames_.size(); ++k) {
    const FrameInfo& frame = frames_[k];
    out << "      <Grid Name=\"frame_" << counter(static_cast<int>(k)) << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << number(listed[k]) << "\"/>\n"
        << "        <Information Name=\"time\" Value=\"" << number(frame.time) << "\"/>\n"
        << "        <Information Name=\"step\" Value=\"" << frame.step << "\"/>\n"
        << "        <Information Name=\"stage\" Value=\"" << xml_escaped(frame.stage) << "\"/>\n"
        << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << frame.particles << "\" NodesPerElement=\"1\"/>\n"
        << "        <Geometry GeometryType=\"XYZ\">\n";
    data_item(frame, "position", 3);
    out << "        </Geometry>\n";
    for (const auto& [name, components] : frame.fields) {
      if (name == "position") continue;
      out << "        <Attribute Name=\"" << xml_escaped(name) << "\" AttributeType=\"" << attribute_type(components)
          << "\" Center=\"Node\">\n";
      data_item(frame, name, components);
      out << "        </Attribute>\n";
    }
    out << "      </Grid>\n";
  }
  out << "    </Grid>\n"
      << "  </Domain>\n"
      << "</Xdmf>\n";
  return out.str();
}

std::string ResultsWriter::csv_text() const {
  std::string out;
  if (columns_.empty()) return out;  // no time series yet: an empty file
  for (std::size_t c = 0; c < columns_.size(); ++c) out += (c ? "," : "") + columns_[c];
  out += '\n';
  for (const std::vector<double>& row : rows_) {
    for (std::size_t c = 0; c < row.size(); ++c) {
      if (c) out += ',';
      out += number(row[c]);
    }
    out += '\n';
  }
  return out;
}

}  // namespace sparkdem::io
