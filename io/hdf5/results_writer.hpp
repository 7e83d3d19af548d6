#pragma once
/// Writes a run's results into an output directory so that a run killed at any moment (SIGKILL,
/// power loss) leaves every frame it has reported readable:
///  - frames/frame_NNNNNN.h5  one complete HDF5 file per frame, written as frame_NNNNNN.h5.tmp,
///                            fsynced and renamed (then the directory fsynced) before
///                            write_frame() returns. Callers report a frame (run.log) only after
///                            that, so a reported frame is always complete on disk.
///  - results.h5              the index: /frames/NNNNNN are HDF5 external links to the frame
///                            files (relative paths, resolved from the directory of results.h5,
///                            so move the output directory as a whole), plus /timeseries;
///  - results.xdmf            XDMF description of the frames for ParaView, pointing straight
///                            into the frame files: a temporal collection "particles" with one
///                            grid per frame (a Polyvertex grid, one point per particle), at
///                            strictly increasing times (see listed_times()), each holding the
///                            frame's true time, step and stage as Information elements (Name
///                            "time" [s], "step", "stage"); and per line set drawn in any frame
///                            ("contacts", "bonds", a module's network such as "electrical") a
///                            temporal collection of that name with one Polyline grid per frame
///                            at the same times, over the same points, one 2-node cell per row and
///                            the rows' fields as cell arrays (an empty grid where the frame has
///                            none): ParaView's XDMF Reader shows one block per collection;
///  - timeseries.csv          the time series as text.
/// The three index files are rewritten together by write_index() (each atomically: tmp, fsync,
/// rename) and by finalize(); the pipeline calls write_index() just before every checkpoint,
/// snapshot and stage-end state file is committed, so after a crash they describe the run up to
/// its last restart point at least (a continuation in place keeps what that point records), while
/// frames/ holds every frame written up to the crash.
///
/// A new writer takes over the directory: it removes the results of an earlier run there (the
/// frame files frames/frame_*.h5, results.h5, results.xdmf, timeseries.csv and tmp files of
/// them); checkpoints and other files are not touched. A writer that continues a run in place
/// (ResultsWriter::Kept: what the folder held at the restart point) keeps the first `frames`
/// frame files and the first `rows` time-series rows of the first `columns` columns (read back
/// from timeseries.csv, whose numbers round-trip exactly), rewrites the index files with just
/// those, then removes every later frame file: the next frame written is frame `frames`. A writer
/// destroyed without finalize() removes only its tmp files: the frames written so far stay.
///
/// Frame file layout (frames/frame_NNNNNN.h5; in results.h5 the same below /frames/NNNNNN):
///   /                   attributes step (int64), time (double), stage (string)
///   /particles/<name>   double, n x components, attribute unit (string)
///   /contacts/pairs     int64, m x 2 (particle ids of each contact)
///   /contacts/<name>    double, m x components, attribute unit (string)
///   /bonds/...          as /contacts, one row per bond (intact or broken), when the frame has bonds
///   /networks/<name>/.. as /contacts, a module's network edges (a wall end has id -1 - wall index)
///   <group>/nodes       int64, m x 2, when the group is drawn as lines: the rows of the two ends in
///                       /particles/* (frames are not in id order); a wall end takes the row of the
///                       other end (a cell of zero length)
/// results.h5 also holds /timeseries/<column>: double, 1-D, one value per row.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace sparkdem::io {

/// One named per-item quantity: n * components values, row-major, held in `data` or, for arrays
/// that outlive the frame's writing (the particles' own columns), viewed through `view` (set:
/// `data` is not read), so a frame does not copy them; or made by `make` (set: `rows` rows) when
/// the writer comes to it and dropped once written, so a frame holds one gathered column at a time.
struct FrameField {
  std::string name;
  int components = 1;
  std::vector<double> data;
  std::string unit;
  std::span<const double> view = {};
  std::function<std::vector<double>()> make = {};
  std::size_t rows = 0;  ///< with `make`: the rows it makes
  std::span<const double> values() const { return view.data() ? view : std::span<const double>(data); }
  /// Values for `rows` rows or fewer (a made field reports its rows; its values come at writing).
  std::size_t size() const { return make ? rows * static_cast<std::size_t>(components) : values().size(); }
};

/// Contacts of one frame: pairs holds 2 particle ids per contact; fields have one row per contact.
struct ContactFrame {
  std::vector<std::int64_t> pairs;
  std::vector<FrameField> fields;
};

/// One frame's content. Edge sets are written at their group: /contacts, /bonds (when `bonds`
/// holds a value) and /networks/<name>. `contact_lines` draws the contacts and the networks as
/// line grids in results.xdmf, `bond_lines` the bonds (output.network); a drawn set gets its
/// /nodes dataset, which needs the particle field "id".
struct FrameContent {
  std::int64_t step = 0;
  double time = 0.0;  ///< [s]
  std::string stage;
  std::vector<FrameField> particles;
  ContactFrame contacts;
  std::optional<ContactFrame> bonds;
  std::vector<std::pair<std::string, ContactFrame>> networks;
  bool contact_lines = false;
  bool bond_lines = false;
};

/// What an index file needs to know about one frame file.
struct FrameInfo {
  /// One edge set drawn as lines.
  struct LineSet {
    std::string name;   ///< the grid's name ("contacts", "bonds", "electrical")
    std::string group;  ///< its group in the frame file ("/contacts", "/networks/electrical")
    std::size_t cells = 0;
    std::vector<std::pair<std::string, int>> fields;  ///< cell field name, components
  };
  std::string file;  ///< relative to the directory of the index file
  double time = 0.0;
  std::int64_t step = 0;
  std::string stage;
  std::size_t particles = 0;
  std::vector<std::pair<std::string, int>> fields;  ///< particle field name, components
  std::vector<LineSet> lines;
};

/// Reads what the index needs from a written frame file (`file` as the index will name it,
/// relative to `dir`). Throws SetupError on a file that is not a frame.
FrameInfo read_frame_info(const std::filesystem::path& dir, const std::string& file);

/// The XDMF text of these frames (results.xdmf's format) listed at `listed` times (one per frame,
/// strictly increasing; see ResultsWriter::listed_times).
std::string xdmf_of_frames(const std::vector<FrameInfo>& frames, const std::vector<double>& listed);

class ResultsWriter {
 public:
  /// What a folder held at a restart point (see the header comment).
  struct Kept {
    int frames = 0;
    std::size_t columns = 0;
    std::size_t rows = 0;
  };
  /// Creates `outdir` and `outdir/frames` if needed and removes an earlier run's results there;
  /// with `keep`, keeps those of them (throws SetupError naming what is missing when the folder
  /// holds less than `keep` says).
  explicit ResultsWriter(std::filesystem::path outdir, const std::optional<Kept>& keep = std::nullopt);
  ResultsWriter(const ResultsWriter&) = delete;
  ResultsWriter& operator=(const ResultsWriter&) = delete;
  /// Removes the tmp files; written frames stay.
  ~ResultsWriter();

  /// Writes the next frame file durably (see above) and returns its path relative to the output
  /// directory. particle_fields must contain "position" with 3 components and all particle
  /// fields must have the same number of rows; contact fields one row per pair. An invalid frame
  /// throws before anything is written.
  /// `networks` are further edge sets (a module's network edges, e.g. branch currents), written
  /// as /networks/<name>/pairs and /networks/<name>/<field>, with the same checks as contacts.
  std::string write_frame(std::int64_t step, double time, const std::string& stage, const std::vector<FrameField>& particle_fields,
                          const ContactFrame& contacts, const std::vector<std::pair<std::string, ContactFrame>>& networks = {});
  /// The same for a frame with bonds and line sets (FrameContent).
  std::string write_frame(const FrameContent& frame);
  /// Sets the time series (each row has one value per column) for the next write_index().
  /// (The index counts as out of date after this call, whatever the values.)
  void set_timeseries(const std::vector<std::string>& columns, const std::vector<std::vector<double>>& rows);
  /// Rewrites results.h5 (links to every frame so far, /timeseries), results.xdmf and
  /// timeseries.csv, each atomically.
  void write_index();
  /// write_index() for the last time, unless the index is up to date (no write_frame() or
  /// set_timeseries() since the last write_index()); no frame can be written afterwards.
  /// Returns whether the index was written.
  bool finalize();
  /// Number of frames written so far.
  int frames() const { return static_cast<int>(frames_.size()); }
  /// The last frame written or kept (none: nullptr).
  const FrameInfo* last_frame() const { return frames_.empty() ? nullptr : &frames_.back(); }
  /// The time series as set last (after a continuation: the rows kept).
  const std::vector<std::string>& columns() const { return columns_; }
  const std::vector<std::vector<double>>& rows() const { return rows_; }
  /// Frame file of frame `index`, relative to the output directory ("frames/frame_000003.h5").
  static std::string frame_file(int index);
  /// Least gap between two times of results.xdmf [s]: ParaView's XDMF reader (XDMFReader)
  /// takes every grid within 2.2e-16 s (DBL_EPSILON, absolute) of the time it shows, and two
  /// grids at one time become an empty multiblock.
  static constexpr double kXdmfTimeGap = 1e-15;
  /// The times results.xdmf lists for frames at `times` (in frame order): strictly increasing
  /// with gaps of at least kXdmfTimeGap, so that every frame is one time step of its own. A time
  /// at least kXdmfTimeGap above the previous listed time is listed as is; an earlier one - the
  /// first frame of a stage at the step and time of the previous stage's last frame - is listed
  /// kXdmfTimeGap after the previous listed time (1 ulp where that is more).
  static std::vector<double> listed_times(const std::vector<double>& times);

 private:
  /// Throws (naming the frame) unless the frame is valid; sets `particles` to its particle count.
  void check_frame(const FrameContent& frame, std::size_t& particles) const;
  void write_results_h5(const std::filesystem::path& file) const;
  std::string xdmf_text() const;
  std::string csv_text() const;
  /// The continuation of a run in place (constructor with `keep`).
  void continue_in(const Kept& keep);
  /// The first `rows` rows of the first `columns` columns of timeseries.csv into columns_, rows_.
  void read_timeseries(std::size_t columns, std::size_t rows);
  /// Throws a SetupError about `what` in this writer's output directory.
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path outdir_;
  std::vector<FrameInfo> frames_;
  std::vector<std::string> columns_;
  std::vector<std::vector<double>> rows_;
  bool index_current_ = false;  ///< the index files on disk describe frames_, columns_, rows_
  bool finalized_ = false;
};

}  // namespace sparkdem::io
