#include "io/hdf5/results_writer.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>
#include <system_error>
#include <unordered_map>
#include <functional>
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

/// The order a frame's index entry lists its fields and line sets in, whoever made it (the writer
/// or read_frame_info from the file): fields by name, then contacts, bonds and the networks by
/// name. A frame's XDMF entry is then the same whether the run wrote the frame or a continuation
/// in place read it back.
void canonical_order(FrameInfo& info) {
  const auto by_name = [](const auto& a, const auto& b) { return a.first < b.first; };
  std::sort(info.fields.begin(), info.fields.end(), by_name);
  for (FrameInfo::LineSet& line : info.lines) std::sort(line.fields.begin(), line.fields.end(), by_name);
  const auto rank = [](const FrameInfo::LineSet& l) { return l.group == "/contacts" ? 0 : l.group == "/bonds" ? 1 : 2; };
  std::stable_sort(info.lines.begin(), info.lines.end(), [&](const FrameInfo::LineSet& a, const FrameInfo::LineSet& b) {
    return rank(a) != rank(b) ? rank(a) < rank(b) : a.name < b.name;
  });
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

ResultsWriter::ResultsWriter(fs::path outdir, const std::optional<Kept>& keep) : outdir_(std::move(outdir)) {
  if (keep)
    continue_in(*keep);
  else
    take_over(outdir_);
}

namespace {

/// The comma-separated fields of one CSV line (the time series has no quoted fields).
std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    out.push_back(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) return out;
    start = comma + 1;
  }
}

}  // namespace

void ResultsWriter::read_timeseries(std::size_t columns, std::size_t rows) {
  columns_.clear();
  rows_.clear();
  if (columns == 0) return;
  std::ifstream in(outdir_ / kCsv);
  if (!in) fail(std::string(kCsv) + " is missing, but the restart point recorded " + std::to_string(rows) + " time-series rows");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header = csv_fields(line);
  if (header.size() < columns)
    fail(std::string(kCsv) + " has " + std::to_string(header.size()) + " columns, the restart point recorded " + std::to_string(columns));
  header.resize(columns);
  columns_ = header;
  for (std::size_t r = 0; r < rows; ++r) {
    if (!std::getline(in, line))
      fail(std::string(kCsv) + " has " + std::to_string(r) + " rows, the restart point recorded " + std::to_string(rows));
    const std::vector<std::string> fields = csv_fields(line);
    if (fields.size() < columns) fail(std::string(kCsv) + " row " + std::to_string(r) + " has too few values");
    std::vector<double> row(columns);
    for (std::size_t c = 0; c < columns; ++c) {
      char* end = nullptr;
      row[c] = std::strtod(fields[c].c_str(), &end);
      if (end == fields[c].c_str() || *end != '\0') fail(std::string(kCsv) + " row " + std::to_string(r) + ": '" + fields[c] + "' is not a number");
    }
    rows_.push_back(std::move(row));
  }
}

void ResultsWriter::continue_in(const Kept& keep) {
  std::error_code ec;
  fs::create_directories(outdir_ / kFrames, ec);
  if (ec) throw SetupError("results directory '" + outdir_.string() + "': cannot create it: " + ec.message());
  // Everything kept is read before anything is removed.
  read_timeseries(keep.columns, keep.rows);
  for (int k = 0; k < keep.frames; ++k) {
    if (!fs::exists(outdir_ / frame_file(k), ec))
      fail(frame_file(k) + " is missing, but the restart point recorded " + std::to_string(keep.frames) + " frames");
    frames_.push_back(read_frame_info(outdir_, frame_file(k)));
  }
  write_index();  // the index first: it must not refer to the frames removed next
  static const std::regex frame_name(R"(frame_([0-9]{6,})\.h5(\.tmp)?)");
  std::smatch m;
  for (const auto& entry : fs::directory_iterator(outdir_ / kFrames, ec)) {
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, m, frame_name) && (m[2].matched || std::stoll(m[1].str()) >= keep.frames)) remove_if_present(entry.path());
  }
  if (ec) fail("cannot list '" + (outdir_ / kFrames).string() + "': " + ec.message());
  sync_directory(outdir_ / kFrames);
}

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
  return write_frame(FrameContent{step, time, stage, particle_fields, contacts, std::nullopt, networks, false, false});
}

namespace {

/// Rows of the two ends of every pair in the frame's particle arrays (FrameContent: a wall end,
/// id < 0, takes the other end's row); `where` names the set in errors.
std::vector<std::int64_t> node_rows(const std::vector<std::int64_t>& pairs, const std::unordered_map<std::int64_t, std::int64_t>& row_of,
                                    const std::function<void(const std::string&)>& fail, const std::string& where) {
  std::vector<std::int64_t> nodes(pairs.size());
  const auto find = [&](std::int64_t id) -> std::int64_t {
    if (id < 0) return -1;
    const auto it = row_of.find(id);
    if (it == row_of.end()) fail(where + ": particle id " + std::to_string(id) + " is not in the frame");
    return it->second;
  };
  for (std::size_t e = 0; e + 1 < pairs.size(); e += 2) {
    std::int64_t a = find(pairs[e]), b = find(pairs[e + 1]);
    if (a < 0 && b < 0) fail(where + ": row " + std::to_string(e / 2) + " joins two walls");
    nodes[e] = a < 0 ? b : a;
    nodes[e + 1] = b < 0 ? a : b;
  }
  return nodes;
}

}  // namespace

void ResultsWriter::check_frame(const FrameContent& frame, std::size_t& particles) const {
  const std::string name = "frame " + counter(frames());
  const auto check_fields = [&](const std::vector<FrameField>& fields, const std::string& kind, std::size_t expected_rows) {
    std::set<std::string> seen;
    for (const FrameField& f : fields) {
      const std::string label = kind + " field '" + f.name + "' of " + name;
      if (!valid_name(f.name, false)) fail(label + ": the name is empty or contains '/'");
      if (kind == "contact" && (f.name == "pairs" || f.name == "nodes")) fail(label + ": the names 'pairs' and 'nodes' are reserved");
      if (!seen.insert(f.name).second) fail(label + ": duplicate field name");
      if (f.components < 1) fail(label + ": components must be at least 1");
      const auto c = static_cast<std::size_t>(f.components);
      const std::size_t size = f.size();
      if (size % c != 0) fail(label + ": " + std::to_string(size) + " values are not a multiple of " + std::to_string(c) + " components");
      if (size / c != expected_rows) fail(label + ": " + std::to_string(size / c) + " rows, expected " + std::to_string(expected_rows));
    }
  };
  bool has_position = false;
  for (const FrameField& f : frame.particles) {
    if (f.name == "position") {
      if (f.components != 3) fail("field 'position' of " + name + " must have 3 components");
      has_position = true;
      particles = f.size() / 3;
    }
  }
  if (!has_position) fail(name + " has no particle field 'position'");
  check_fields(frame.particles, "particle", particles);
  const auto check_set = [&](const std::string& what, const ContactFrame& set) {
    if (set.pairs.size() % 2 != 0) fail(what + " of " + name + ": pairs hold an odd number of ids");
    check_fields(set.fields, "contact", set.pairs.size() / 2);
  };
  check_set("contacts", frame.contacts);
  if (frame.bonds) check_set("bonds", *frame.bonds);
  std::set<std::string> network_names;
  for (const auto& [nname, net] : frame.networks) {
    if (!valid_name(nname, false) || !network_names.insert(nname).second)
      fail("network '" + nname + "' of " + name + ": the name is empty, contains '/' or is repeated");
    check_set("network '" + nname + "'", net);
  }
}

std::string ResultsWriter::write_frame(const FrameContent& frame) {
  if (finalized_) fail("write_frame() called after finalize()");
  // Validate everything before writing anything, so a bad frame leaves no file.
  std::size_t particles = 0;
  check_frame(frame, particles);
  struct Set {
    std::string name, group;
    const ContactFrame* edges;
    bool lines;
  };
  std::vector<Set> sets{{"contacts", "/contacts", &frame.contacts, frame.contact_lines}};
  if (frame.bonds) sets.push_back({"bonds", "/bonds", &*frame.bonds, frame.bond_lines});
  for (const auto& [nname, net] : frame.networks) sets.push_back({nname, "/networks/" + nname, &net, frame.contact_lines});
  std::unordered_map<std::int64_t, std::int64_t> row_of;
  std::vector<std::vector<std::int64_t>> nodes(sets.size());
  if (std::any_of(sets.begin(), sets.end(), [](const Set& x) { return x.lines && !x.edges->pairs.empty(); })) {
    const auto id = std::find_if(frame.particles.begin(), frame.particles.end(), [](const FrameField& f) { return f.name == "id"; });
    if (id == frame.particles.end() || id->components != 1) fail("frame " + counter(frames()) + " draws lines but has no particle field 'id'");
    row_of.reserve(particles);
    const std::span<const double> ids = id->values();
    for (std::size_t r = 0; r < particles; ++r) row_of.emplace(static_cast<std::int64_t>(ids[r]), static_cast<std::int64_t>(r));
    for (std::size_t k = 0; k < sets.size(); ++k)
      if (sets[k].lines)
        nodes[k] = node_rows(sets[k].edges->pairs, row_of, [this](const std::string& w) { fail(w); },
                             sets[k].name + " of frame " + counter(frames()));
  }

  const std::string relative = frame_file(frames());
  const fs::path final_path = outdir_ / relative;
  TmpGuard tmp{tmp_name(final_path)};
  FrameInfo info{relative, frame.time, frame.step, frame.stage, particles, {}, {}};
  {
    H5File file = H5File::create(tmp.file);
    file.set_attribute("/", "step", frame.step);
    file.set_attribute("/", "time", frame.time);
    file.set_attribute("/", "stage", frame.stage);
    // A made field's values exist only while it is written.
    const auto write_field = [&](const std::string& path, const FrameField& f) {
      const std::vector<double> made = f.make ? f.make() : std::vector<double>();
      if (f.make && made.size() != f.size())
        fail("field '" + path + "' of frame " + counter(frames()) + ": made " + std::to_string(made.size()) + " values, expected " +
             std::to_string(f.size()));
      file.write(path, f.make ? std::span<const double>(made) : f.values(), f.components);
      file.set_attribute(path, "unit", f.unit);
    };
    file.create_group("/particles");
    for (const FrameField& f : frame.particles) {
      write_field("/particles/" + f.name, f);
      info.fields.emplace_back(f.name, f.components);
    }
    for (std::size_t k = 0; k < sets.size(); ++k) {
      const Set& set = sets[k];
      file.create_group(set.group);
      file.write(set.group + "/pairs", set.edges->pairs, 2);
      FrameInfo::LineSet line{set.name, set.group, set.edges->pairs.size() / 2, {}};
      if (set.lines) file.write(set.group + "/nodes", nodes[k], 2);
      for (const FrameField& f : set.edges->fields) {
        write_field(set.group + "/" + f.name, f);
        line.fields.emplace_back(f.name, f.components);
      }
      if (set.lines) info.lines.push_back(std::move(line));
    }
    file.close();
  }
  commit_file(tmp.file, final_path);
  tmp.armed = false;
  canonical_order(info);
  frames_.push_back(std::move(info));
  index_current_ = false;
  return relative;
}

FrameInfo read_frame_info(const fs::path& dir, const std::string& file) {
  try {
    const H5File h5 = H5File::open_read(dir / file);
    FrameInfo info{file, h5.attribute_double("/", "time"), h5.attribute_int64("/", "step"), h5.attribute_string("/", "stage"), 0, {}, {}};
    const auto width = [](const std::vector<std::size_t>& shape) { return shape.size() > 1 ? static_cast<int>(shape[1]) : 1; };
    info.particles = h5.shape("/particles/position").at(0);
    for (const std::string& name : h5.children("/particles")) info.fields.emplace_back(name, width(h5.shape("/particles/" + name)));
    std::vector<std::pair<std::string, std::string>> groups{{"contacts", "/contacts"}, {"bonds", "/bonds"}};
    if (h5.exists("/networks"))
      for (const std::string& name : h5.children("/networks")) groups.emplace_back(name, "/networks/" + name);
    for (const auto& [name, group] : groups) {
      if (!h5.exists(group + "/nodes")) continue;
      FrameInfo::LineSet line{name, group, h5.shape(group + "/nodes").at(0), {}};
      for (const std::string& f : h5.children(group))
        if (f != "pairs" && f != "nodes") line.fields.emplace_back(f, width(h5.shape(group + "/" + f)));
      info.lines.push_back(std::move(line));
    }
    canonical_order(info);
    return info;
  } catch (const std::out_of_range&) { throw SetupError("frame file '" + (dir / file).string() + "': a dataset has no rows dimension"); }
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
  std::vector<double> times;
  for (const FrameInfo& frame : frames_) times.push_back(frame.time);
  return xdmf_of_frames(frames_, listed_times(times));
}

namespace {

/// One HDF DataItem of a frame file's dataset.
void data_item(std::ostringstream& out, const std::string& indent, const std::string& file, const std::string& path, std::size_t rows,
               int components, bool integer) {
  out << indent << "<DataItem Dimensions=\"" << rows << ' ' << components << "\" NumberType=\"" << (integer ? "Int" : "Float")
      << "\" Precision=\"8\" Format=\"HDF\">" << xml_escaped(file) << ':' << xml_escaped(path) << "</DataItem>\n";
}

/// The grid of a frame's particles (`name`: its Name attribute).
void particle_grid(std::ostringstream& out, const std::string& indent, const FrameInfo& frame, const std::string& name,
                   const std::string& header) {
  out << indent << "<Grid Name=\"" << name << "\" GridType=\"Uniform\">\n"
      << header << indent << "  <Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << frame.particles
      << "\" NodesPerElement=\"1\"/>\n"
      << indent << "  <Geometry GeometryType=\"XYZ\">\n";
  data_item(out, indent + "    ", frame.file, "/particles/position", frame.particles, 3, false);
  out << indent << "  </Geometry>\n";
  for (const auto& [field, components] : frame.fields) {
    if (field == "position") continue;
    out << indent << "  <Attribute Name=\"" << xml_escaped(field) << "\" AttributeType=\"" << attribute_type(components)
        << "\" Center=\"Node\">\n";
    data_item(out, indent + "    ", frame.file, "/particles/" + field, frame.particles, components, false);
    out << indent << "  </Attribute>\n";
  }
  out << indent << "</Grid>\n";
}

/// A line set's grid: 2-node Polyline cells over the particle positions, its fields as cell
/// arrays; `line` null or without cells: an empty grid (no DataItem: the readers refuse an empty
/// HDF DataItem but take a topology of no elements).
void line_grid(std::ostringstream& out, const std::string& indent, const FrameInfo& frame, const FrameInfo::LineSet* line,
               const std::string& name, const std::string& time) {
  const std::size_t cells = line ? line->cells : 0;
  out << indent << "<Grid Name=\"" << xml_escaped(name) << "\" GridType=\"Uniform\">\n"
      << indent << "  <Time Value=\"" << time << "\"/>\n"
      << indent << "  <Topology TopologyType=\"Polyline\" NumberOfElements=\"" << cells << "\" NodesPerElement=\"2\"";
  if (cells == 0) {
    out << "/>\n";
  } else {
    out << ">\n";
    data_item(out, indent + "    ", frame.file, line->group + "/nodes", cells, 2, true);
    out << indent << "  </Topology>\n";
  }
  out << indent << "  <Geometry GeometryType=\"XYZ\">\n";  // (a grid without one crashes the reader)
  data_item(out, indent + "    ", frame.file, "/particles/position", frame.particles, 3, false);
  out << indent << "  </Geometry>\n";
  if (cells == 0) {
    out << indent << "</Grid>\n";
    return;
  }
  for (const auto& [field, components] : line->fields) {
    out << indent << "  <Attribute Name=\"" << xml_escaped(field) << "\" AttributeType=\"" << attribute_type(components)
        << "\" Center=\"Cell\">\n";
    data_item(out, indent + "    ", frame.file, line->group + "/" + field, cells, components, false);
    out << indent << "  </Attribute>\n";
  }
  out << indent << "</Grid>\n";
}

}  // namespace

std::string xdmf_of_frames(const std::vector<FrameInfo>& frames, const std::vector<double>& listed) {
  // One temporal collection per grid kind, each with one entry per frame at the same times:
  // ParaView's XDMFReader then gives a multiblock whose blocks keep their names ("particles",
  // "contacts", ...) at every time step (grids of one name in two entries would be renamed
  // "particles[1]", ...). A frame without cells in a line set gets an empty grid there.
  std::vector<std::string> line_names;
  for (const FrameInfo& frame : frames)
    for (const FrameInfo::LineSet& line : frame.lines)
      if (std::find(line_names.begin(), line_names.end(), line.name) == line_names.end()) line_names.push_back(line.name);
  std::ostringstream out;
  out << "<?xml version=\"1.0\" ?>\n"
      << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
      << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
      << "  <Domain>\n"
      << "    <Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const FrameInfo& frame = frames[k];
    std::ostringstream header;
    header << "        <Time Value=\"" << number(listed.at(k)) << "\"/>\n"
           << "        <Information Name=\"time\" Value=\"" << number(frame.time) << "\"/>\n"
           << "        <Information Name=\"step\" Value=\"" << frame.step << "\"/>\n"
           << "        <Information Name=\"stage\" Value=\"" << xml_escaped(frame.stage) << "\"/>\n";
    particle_grid(out, "      ", frame, "frame_" + counter(static_cast<int>(k)), header.str());
  }
  out << "    </Grid>\n";
  for (const std::string& name : line_names) {
    out << "    <Grid Name=\"" << xml_escaped(name) << "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
    for (std::size_t k = 0; k < frames.size(); ++k) {
      const auto& lines = frames[k].lines;
      const auto line = std::find_if(lines.begin(), lines.end(), [&](const FrameInfo::LineSet& l) { return l.name == name; });
      line_grid(out, "      ", frames[k], line == lines.end() ? nullptr : &*line, name + "_" + counter(static_cast<int>(k)),
                number(listed.at(k)));
    }
    out << "    </Grid>\n";
  }
  out << "  </Domain>\n"
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
