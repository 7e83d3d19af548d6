#include "io/hdf5/results_writer.hpp"

#include <cstdio>
#include <fstream>
#include <set>
#include <system_error>
#include <utility>

#include "engine/core/error.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

constexpr const char* kResults = "results.h5";
constexpr const char* kXdmf = "results.xdmf";
constexpr const char* kCsv = "timeseries.csv";

fs::path tmp_of(const fs::path& file) {
  fs::path tmp = file;
  tmp += ".tmp";
  return tmp;
}

/// Creates the output directory, then the tmp results file inside it.
H5File create_results(const fs::path& outdir) {
  std::error_code ec;
  fs::create_directories(outdir, ec);
  if (ec) throw SetupError("results directory '" + outdir.string() + "': cannot create it: " + ec.message());
  return H5File::create(tmp_of(outdir / kResults));
}

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
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

/// XDMF attribute type for a field with this many components.
const char* attribute_type(int components) {
  switch (components) {
    case 1: return "Scalar";
    case 3: return "Vector";
    case 6: return "Tensor6";
    case 9: return "Tensor";
    default: return "Matrix";
  }
}

/// A name usable as an HDF5 link name (and a CSV column when `csv`).
bool valid_name(const std::string& name, bool csv) {
  if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos) return false;
  return !csv || name.find_first_of(",\"\r\n") == std::string::npos;
}

void rename_or_throw(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) throw SetupError("cannot rename '" + from.string() + "' to '" + to.string() + "': " + ec.message());
}

}  // namespace

ResultsWriter::ResultsWriter(fs::path outdir) : outdir_(std::move(outdir)), file_(create_results(outdir_)) {}

ResultsWriter::~ResultsWriter() {
  if (finalized_) return;
  try {
    file_.close();
  } catch (const SetupError&) {
    // The results are being discarded anyway.
  }
  std::error_code ec;
  for (const char* name : {kResults, kXdmf, kCsv}) fs::remove(tmp_of(outdir_ / name), ec);
}

void ResultsWriter::fail(const std::string& what) const {
  throw SetupError("results file '" + (outdir_ / kResults).string() + "': " + what);
}

void ResultsWriter::write_frame(std::int64_t step, double time, const std::string& stage,
                                const std::vector<FrameField>& particle_fields, const ContactFrame& contacts) {
  if (finalized_) fail("write_frame() called after finalize()");
  char counter[16];
  std::snprintf(counter, sizeof counter, "%06d", frames());
  const std::string group = std::string("/frames/") + counter;

  // Validate everything before writing anything, so a bad frame leaves no partial group.
  const auto check_fields = [&](const std::vector<FrameField>& fields, const std::string& kind,
                                std::size_t expected_rows) {
    std::set<std::string> seen;
    for (const FrameField& f : fields) {
      const std::string label = kind + " field '" + f.name + "' of frame " + group;
      if (!valid_name(f.name, false)) fail(label + ": the name is empty or contains '/'");
      if (kind == "contact" && f.name == "pairs") fail(label + ": the name 'pairs' is reserved");
      if (!seen.insert(f.name).second) fail(label + ": duplicate field name");
      if (f.components < 1) fail(label + ": components must be at least 1");
      const auto c = static_cast<std::size_t>(f.components);
      if (f.data.size() % c != 0)
        fail(label + ": " + std::to_string(f.data.size()) + " values are not a multiple of " + std::to_string(c) +
             " components");
      if (f.data.size() / c != expected_rows)
        fail(label + ": " + std::to_string(f.data.size() / c) + " rows, expected " + std::to_string(expected_rows));
    }
  };
  std::size_t particles = 0;
  bool has_position = false;
  for (const FrameField& f : particle_fields) {
    if (f.name == "position") {
      if (f.components != 3) fail("field 'position' of frame " + group + " must have 3 components");
      has_position = true;
      particles = f.data.size() / 3;
    }
  }
  if (!has_position) fail("frame " + group + " has no particle field 'position'");
  check_fields(particle_fields, "particle", particles);
  if (contacts.pairs.size() % 2 != 0) fail("contact pairs of frame " + group + " hold an odd number of ids");
  check_fields(contacts.fields, "contact", contacts.pairs.size() / 2);

  file_.create_group(group);
  file_.set_attribute(group, "step", step);
  file_.set_attribute(group, "time", time);
  file_.set_attribute(group, "stage", stage);
  FrameInfo info{group, time, particles, {}};
  file_.create_group(group + "/particles");
  for (const FrameField& f : particle_fields) {
    const std::string path = group + "/particles/" + f.name;
    file_.write(path, f.data, f.components);
    file_.set_attribute(path, "unit", f.unit);
    info.fields.emplace_back(f.name, f.components);
  }
  file_.create_group(group + "/contacts");
  file_.write(group + "/contacts/pairs", contacts.pairs, 2);
  for (const FrameField& f : contacts.fields) {
    const std::string path = group + "/contacts/" + f.name;
    file_.write(path, f.data, f.components);
    file_.set_attribute(path, "unit", f.unit);
  }
  frames_.push_back(std::move(info));
}

void ResultsWriter::set_timeseries(const std::vector<std::string>& columns,
                                   const std::vector<std::vector<double>>& rows) {
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
}

void ResultsWriter::finalize() {
  if (finalized_) fail("finalize() called twice");
  file_.create_group("/timeseries");
  for (std::size_t c = 0; c < columns_.size(); ++c) {
    std::vector<double> column(rows_.size());
    for (std::size_t r = 0; r < rows_.size(); ++r) column[r] = rows_[r][c];
    file_.write("/timeseries/" + columns_[c], column);
  }
  file_.close();
  write_xdmf(tmp_of(outdir_ / kXdmf));
  write_csv(tmp_of(outdir_ / kCsv));
  // results.xdmf last: it refers to results.h5.
  rename_or_throw(tmp_of(outdir_ / kCsv), outdir_ / kCsv);
  rename_or_throw(tmp_of(outdir_ / kResults), outdir_ / kResults);
  rename_or_throw(tmp_of(outdir_ / kXdmf), outdir_ / kXdmf);
  finalized_ = true;
}

void ResultsWriter::write_xdmf(const fs::path& file) const {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw SetupError("cannot create '" + file.string() + "'");
  const auto data_item = [&](const FrameInfo& frame, const std::string& field, int components) {
    out << "          <DataItem Dimensions=\"" << frame.particles << ' ' << components
        << "\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">" << kResults << ':'
        << xml_escaped(frame.group + "/particles/" + field) << "</DataItem>\n";
  };
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
      << "  <Domain>\n"
      << "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (const FrameInfo& frame : frames_) {
    out << "      <Grid Name=\"frame_" << frame.group.substr(frame.group.rfind('/') + 1) << "\" GridType=\"Uniform\">\n"
        << "        <Time Value=\"" << number(frame.time) << "\"/>\n"
        << "        <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << frame.particles
        << "\" NodesPerElement=\"1\"/>\n"
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
  out.close();
  if (!out) throw SetupError("cannot write '" + file.string() + "'");
}

void ResultsWriter::write_csv(const fs::path& file) const {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw SetupError("cannot create '" + file.string() + "'");
  for (std::size_t c = 0; c < columns_.size(); ++c) out << (c ? "," : "") << columns_[c];
  out << '\n';
  for (const std::vector<double>& row : rows_) {
    for (std::size_t c = 0; c < row.size(); ++c) out << (c ? "," : "") << number(row[c]);
    out << '\n';
  }
  out.close();
  if (!out) throw SetupError("cannot write '" + file.string() + "'");
}

}  // namespace sparkdem::io
