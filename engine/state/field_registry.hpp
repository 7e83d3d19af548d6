#pragma once
/// Optional per-particle (or per-contact) fields, created only when an active module or law
/// declares them. A scene that does not need a field never allocates it. Every field is
/// permuted together with the core arrays, written to outputs and stored in checkpoints.
#include <map>
#include <string>
#include <vector>

#include "engine/core/archive.hpp"
#include "engine/core/error.hpp"

namespace sparkdem {

/// What the run watchdog (engine/watchdog.hpp) requires of a field's values.
enum class FieldCheck {
  None,         ///< not checked
  Finite,       ///< a NaN or an infinity stops the run
  NotInfinite,  ///< an infinity stops the run; NaN is a legitimate "undefined" (e.g. a floating potential)
};

struct FieldInfo {
  std::string name;
  int components = 1;                   ///< values per row
  std::string unit;                     ///< SI unit
  double init = 0.0;                    ///< initial value of every component
  bool output = true;                   ///< written to result frames
  FieldCheck check = FieldCheck::None;  ///< watchdog check (not stored in checkpoints: modules re-declare it)
};

class FieldRegistry {
 public:
  /// Declare (or re-declare identically) a field; allocates `rows` rows set to init.
  void declare(const FieldInfo& info, std::size_t rows) {
    auto it = fields_.find(info.name);
    if (it != fields_.end()) {
      if (it->second.info.components != info.components)
        throw SetupError("field '" + info.name + "' declared twice with different component counts");
      // The strictest watchdog check of all declarations holds (a field restored from a
      // checkpoint has none until its module declares it again).
      if (info.check == FieldCheck::Finite || it->second.info.check == FieldCheck::None) it->second.info.check = info.check;
      return;
    }
    Entry e{info, std::vector<double>(rows * info.components, info.init)};
    fields_.emplace(info.name, std::move(e));
  }
  bool has(const std::string& name) const { return fields_.count(name) != 0; }
  /// Drop a field (no-op if absent).
  void remove(const std::string& name) { fields_.erase(name); }
  std::vector<double>& data(const std::string& name) { return get(name).data; }
  const std::vector<double>& data(const std::string& name) const { return const_cast<FieldRegistry*>(this)->get(name).data; }
  const FieldInfo& info(const std::string& name) const { return const_cast<FieldRegistry*>(this)->get(name).info; }
  std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& [k, v] : fields_) n.push_back(k);
    return n;
  }
  std::size_t size() const { return fields_.size(); }

  /// new[i] = old[perm[i]] for every field.
  void permute(const std::vector<Index>& perm) {
    for (auto& [k, e] : fields_) {
      const int c = e.info.components;
      std::vector<double> out(perm.size() * c);
      for (std::size_t i = 0; i < perm.size(); ++i)
        for (int q = 0; q < c; ++q) out[i * c + q] = e.data[static_cast<std::size_t>(perm[i]) * c + q];
      e.data.swap(out);
    }
  }
  /// Grow/shrink every field to `rows` rows (new rows take the init value).
  void resize(std::size_t rows) {
    for (auto& [k, e] : fields_) e.data.resize(rows * e.info.components, e.info.init);
  }
  /// Store/restore every field under prefix/<name>; on reading, fields missing from the registry
  /// are re-created from the stored list (so a restart needs no prior declaration).
  void visit(Archive& ar, const std::string& prefix) {
    std::string list;
    for (const auto& [k, e] : fields_)
      list += k + "|" + std::to_string(e.info.components) + "|" + e.info.unit + "|" + (e.info.output ? "1" : "0") + "\n";
    ar.visit(prefix + "/_list", list);
    if (ar.reading()) {
      std::size_t pos = 0;
      while (pos < list.size()) {
        std::size_t end = list.find('\n', pos);
        if (end == std::string::npos) end = list.size();
        const std::string line = list.substr(pos, end - pos);
        pos = end + 1;
        // name|components|unit|output, components a small positive integer
        const auto a = line.find('|');
        const auto b = a == std::string::npos ? a : line.find('|', a + 1);
        const auto c = b == std::string::npos ? b : line.find('|', b + 1);
        const std::string comps = c == std::string::npos ? std::string() : line.substr(a + 1, b - a - 1);
        if (c == std::string::npos || a == 0 || comps.empty() || comps.size() > 4 ||
            comps.find_first_not_of("0123456789") != std::string::npos || std::stoi(comps) < 1 || std::stoi(comps) > 1000)
          throw SetupError("checkpoint field list '" + prefix + "/_list': malformed line '" + line.substr(0, 80) +
                           "' (expected name|components|unit|output)");
        FieldInfo info{line.substr(0, a), std::stoi(comps), line.substr(b + 1, c - b - 1), 0.0, line.substr(c + 1) == "1"};
        declare(info, 0);
      }
    }
    for (auto& [k, e] : fields_) ar.visit(prefix + "/" + k, e.data, e.info.components);
  }

 private:
  struct Entry {
    FieldInfo info;
    std::vector<double> data;
  };
  Entry& get(const std::string& name) {
    auto it = fields_.find(name);
    if (it == fields_.end()) throw SetupError("field '" + name + "' was not declared by any active module");
    return it->second;
  }
  std::map<std::string, Entry> fields_;
};

}  // namespace sparkdem
