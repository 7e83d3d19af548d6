#pragma once
/// Writes a run's results into an output directory:
///  - results.h5    frames of per-particle and per-contact fields, plus the time series;
///  - results.xdmf  XDMF description of the particle frames, for ParaView;
///  - timeseries.csv the time series as text.
/// Everything is written under tmp names and renamed by finalize(); a writer destroyed
/// without finalize() removes its tmp files, so the directory never holds half-written output.
///
/// results.h5 layout:
///   /frames/NNNNNN                  group per frame (zero-padded counter), attributes
///                                   step (int64), time (double), stage (string)
///   /frames/NNNNNN/particles/<name> double, n x components, attribute unit (string)
///   /frames/NNNNNN/contacts/pairs   int64, m x 2 (particle ids of each contact)
///   /frames/NNNNNN/contacts/<name>  double, m x components, attribute unit (string)
///   /timeseries/<column>            double, 1-D, one value per row
#include <cstdint>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "io/hdf5/h5file.hpp"

namespace sparkdem::io {

/// One named per-item quantity: data holds n * components values, row-major.
struct FrameField {
  std::string name;
  int components = 1;
  std::vector<double> data;
  std::string unit;
};

/// Contacts of one frame: pairs holds 2 particle ids per contact; fields have one row per contact.
struct ContactFrame {
  std::vector<std::int64_t> pairs;
  std::vector<FrameField> fields;
};

class ResultsWriter {
 public:
  /// Creates `outdir` if needed and starts `outdir/results.h5.tmp`.
  explicit ResultsWriter(std::filesystem::path outdir);
  ResultsWriter(const ResultsWriter&) = delete;
  ResultsWriter& operator=(const ResultsWriter&) = delete;
  /// Without finalize(): closes and removes the tmp files.
  ~ResultsWriter();

  /// Appends one frame. particle_fields must contain "position" with 3 components and all
  /// particle fields must have the same number of rows; contact fields one row per pair.
  void write_frame(std::int64_t step, double time, const std::string& stage,
                   const std::vector<FrameField>& particle_fields, const ContactFrame& contacts);
  /// Sets the time series (each row has one value per column); written by finalize().
  void set_timeseries(const std::vector<std::string>& columns, const std::vector<std::vector<double>>& rows);
  /// Writes /timeseries, closes results.h5, writes results.xdmf and timeseries.csv, and
  /// renames every tmp file to its final name.
  void finalize();
  /// Number of frames written so far.
  int frames() const { return static_cast<int>(frames_.size()); }

 private:
  /// What results.xdmf needs to know about one frame.
  struct FrameInfo {
    std::string group;  ///< "/frames/NNNNNN"
    double time;
    std::size_t particles;
    std::vector<std::pair<std::string, int>> fields;  ///< particle field name, components
  };
  void write_xdmf(const std::filesystem::path& file) const;
  void write_csv(const std::filesystem::path& file) const;
  /// Throws a SetupError about `what` in this writer's results file.
  [[noreturn]] void fail(const std::string& what) const;

  std::filesystem::path outdir_;
  H5File file_;
  std::vector<FrameInfo> frames_;
  std::vector<std::string> columns_;
  std::vector<std::vector<double>> rows_;
  bool finalized_ = false;
};

}  // namespace sparkdem::io
