#pragma once
/// Checkpoint archive: one visit() per item serves both writing and reading (GROMACS
/// CheckpointData style). The engine only sees this interface; io/restart implements it in HDF5.
/// Names are '/'-separated paths ("particles/position"); parents are created as needed.
#include <cstdint>
#include <string>
#include <vector>

#include "engine/core/types.hpp"

namespace sparkdem {

class Archive {
 public:
  virtual ~Archive() = default;
  /// True when restoring from a checkpoint, false when writing one.
  virtual bool reading() const = 0;
  /// True if an item of this name exists (reading) — lets optional items be skipped.
  virtual bool has(const std::string& name) const = 0;
  /// Array of doubles with `components` values per row (rows = size/components).
  virtual void visit(const std::string& name, std::vector<double>& v, int components = 1) = 0;
  virtual void visit(const std::string& name, std::vector<std::int64_t>& v, int components = 1) = 0;
  virtual void visit(const std::string& name, double& x) = 0;
  virtual void visit(const std::string& name, std::int64_t& x) = 0;
  virtual void visit(const std::string& name, std::string& s) = 0;

  /// Helpers for Eigen arrays (flattened row-major, N x 3 and N x 4 [w,x,y,z]).
  void visit(const std::string& name, std::vector<Vec3>& v) {
    std::vector<double> flat;
    if (!reading()) {
      flat.resize(3 * v.size());
      for (std::size_t i = 0; i < v.size(); ++i)
        for (int k = 0; k < 3; ++k) flat[3 * i + k] = v[i][k];
    }
    visit(name, flat, 3);
    if (reading()) {
      v.resize(flat.size() / 3);
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = Vec3(flat[3 * i], flat[3 * i + 1], flat[3 * i + 2]);
    }
  }
  void visit(const std::string& name, std::vector<Quat>& v) {
    std::vector<double> flat;
    if (!reading()) {
      flat.resize(4 * v.size());
      for (std::size_t i = 0; i < v.size(); ++i) {
        flat[4 * i] = v[i].w();
        flat[4 * i + 1] = v[i].x();
        flat[4 * i + 2] = v[i].y();
        flat[4 * i + 3] = v[i].z();
      }
    }
    visit(name, flat, 4);
    if (reading()) {
      v.resize(flat.size() / 4);
      for (std::size_t i = 0; i < v.size(); ++i) v[i] = Quat(flat[4 * i], flat[4 * i + 1], flat[4 * i + 2], flat[4 * i + 3]);
    }
  }
  void visit(const std::string& name, std::vector<std::int32_t>& v) {
    std::vector<std::int64_t> w(v.begin(), v.end());
    visit(name, w, 1);
    if (reading()) v.assign(w.begin(), w.end());
  }
  void visit(const std::string& name, bool& b) {
    std::int64_t x = b ? 1 : 0;
    visit(name, x);
    b = x != 0;
  }
};

}  // namespace sparkdem
