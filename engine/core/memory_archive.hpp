#pragma once
/// An Archive held in memory: the run watchdog's copy of the last healthy state (see
/// engine/watchdog.hpp and io/scenario/pipeline.cpp). Writing stores every visited item under its
/// name; replay() writes the stored items, unchanged, into another (writing) archive, e.g. an
/// HDF5 checkpoint, so a checkpoint can be written later from a state that has moved on since.
///
/// A writing pass starts with begin(): items are overwritten in place (their vectors keep their
/// capacity, so repeated snapshots of a state of steady size allocate nothing), and end() drops
/// the items the pass did not visit (a field removed, a wall gone since the previous snapshot).
/// Reading (after set_reading()) returns the stored items, as a restart would.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/error.hpp"

namespace sparkdem {

class MemoryArchive final : public Archive {
 public:
  /// Starts a writing pass (the archive is in writing mode afterwards).
  void begin() {
    reading_ = false;
    ++pass_;
  }
  /// Ends a writing pass: drops the items it did not visit.
  void end() {
    std::erase_if(items_, [this](const auto& kv) { return kv.second.pass != pass_; });
  }
  /// Switches to reading the stored items.
  void set_reading() { reading_ = true; }
  void clear() { items_.clear(); }
  bool empty() const { return items_.empty(); }
  /// Bytes held by the stored values (capacity not counted).
  std::size_t bytes() const {
    std::size_t b = 0;
    for (const auto& [k, it] : items_) b += 8 * (it.reals.size() + it.ints.size()) + it.text.size() + 16;
    return b;
  }
  /// Writes every stored item into `out` (a writing archive), in name order.
  void replay(Archive& out) {
    for (auto& [name, it] : items_) {
      switch (it.kind) {
        case Kind::Reals:
          out.visit(name, it.reals, it.components);
          break;
        case Kind::Ints:
          out.visit(name, it.ints, it.components);
          break;
        case Kind::Real:
          out.visit(name, it.real);
          break;
        case Kind::Int:
          out.visit(name, it.integer);
          break;
        case Kind::Text:
          out.visit(name, it.text);
          break;
      }
    }
  }

  bool reading() const override { return reading_; }
  bool has(const std::string& name) const override { return items_.count(name) != 0; }
  using Archive::visit;
  void visit(const std::string& name, std::vector<double>& v, int components = 1) override {
    if (reading_) {
      v = get(name, Kind::Reals).reals;
      return;
    }
    Item& it = put(name, Kind::Reals);
    it.reals.assign(v.begin(), v.end());
    it.components = components;
  }
  void visit(const std::string& name, std::vector<std::int64_t>& v, int components = 1) override {
    if (reading_) {
      v = get(name, Kind::Ints).ints;
      return;
    }
    Item& it = put(name, Kind::Ints);
    it.ints.assign(v.begin(), v.end());
    it.components = components;
  }
  void visit(const std::string& name, double& x) override {
    if (reading_) {
      x = get(name, Kind::Real).real;
      return;
    }
    put(name, Kind::Real).real = x;
  }
  void visit(const std::string& name, std::int64_t& x) override {
    if (reading_) {
      x = get(name, Kind::Int).integer;
      return;
    }
    put(name, Kind::Int).integer = x;
  }
  void visit(const std::string& name, std::string& s) override {
    if (reading_) {
      s = get(name, Kind::Text).text;
      return;
    }
    put(name, Kind::Text).text.assign(s);
  }

 private:
  enum class Kind { Reals, Ints, Real, Int, Text };
  struct Item {
    Kind kind = Kind::Real;
    int components = 1;
    std::vector<double> reals;
    std::vector<std::int64_t> ints;
    double real = 0.0;
    std::int64_t integer = 0;
    std::string text;
    std::uint64_t pass = 0;
  };
  Item& put(const std::string& name, Kind kind) {
    Item& it = items_[name];
    it.kind = kind;
    it.pass = pass_;
    return it;
  }
  const Item& get(const std::string& name, Kind kind) const {
    const auto f = items_.find(name);
    if (f == items_.end()) throw SetupError("in-memory state: no item '" + name + "'");
    if (f->second.kind != kind) throw SetupError("in-memory state: item '" + name + "' has another type");
    return f->second;
  }
  std::map<std::string, Item> items_;
  std::uint64_t pass_ = 0;
  bool reading_ = false;
};

/// A writing Archive that keeps nothing: it adds up the bytes a checkpoint of the visited items
/// would hold (8 a number, 1 a character), so a caller can learn a state's size before choosing
/// where to copy it.
class ByteCountArchive final : public Archive {
 public:
  std::size_t bytes() const { return bytes_; }
  bool reading() const override { return false; }
  bool has(const std::string&) const override { return false; }
  using Archive::visit;
  void visit(const std::string&, std::vector<double>& v, int) override { bytes_ += 8 * v.size(); }
  void visit(const std::string&, std::vector<std::int64_t>& v, int) override { bytes_ += 8 * v.size(); }
  void visit(const std::string&, double&) override { bytes_ += 8; }
  void visit(const std::string&, std::int64_t&) override { bytes_ += 8; }
  void visit(const std::string&, std::string& s) override { bytes_ += s.size(); }

 private:
  std::size_t bytes_ = 0;
};

}  // namespace sparkdem
