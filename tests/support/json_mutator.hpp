#pragma once
/// Seeded structure-aware mutations of JSON scenarios, for fuzzing the scenario loader
/// (tests/scenario/test_fuzz_loader.cpp, tests/fuzz/fuzz_driver.cpp).
///
/// mutate(): the original seven mutations (delete a key or element, replace a value by another
/// type / NaN / inf / huge / negative / empty / deeply nested value, duplicate array elements,
/// rename keys, copy subtrees, scale numbers, set names from the scene vocabulary); its sequence
/// of random draws is kept as it was so the seeded CI test keeps its cases.
/// mutate_extended(): those plus huge arrays, strings that look like numbers ("NaN", "-0",
/// "1e999"), file names in the fields that name files ("$include", "csv", "from_snapshot",
/// "size_distribution.csv") including special files (/dev/zero, a directory, a missing file),
/// duplicated keys of other objects, wrapping a value in an array or object and swapping
/// subtrees.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

namespace sparkdem::test {

using JsonPtr = nlohmann::json::json_pointer;

inline void collect(const nlohmann::json& j, const JsonPtr& p, std::vector<JsonPtr>& nodes, std::set<std::string>& keys) {
  nodes.push_back(p);
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) {
      keys.insert(it.key());
      collect(it.value(), p / it.key(), nodes, keys);
    }
  else if (j.is_array())
    for (std::size_t k = 0; k < j.size(); ++k) collect(j[k], p / k, nodes, keys);
}

class JsonMutator {
 public:
  explicit JsonMutator(std::uint64_t seed) : rng_(seed) {}

  /// One random mutation of `j` (in place); returns a description for failure reports.
  std::string mutate(nlohmann::json& j) {
    std::vector<JsonPtr> nodes;
    std::set<std::string> keyset;
    collect(j, JsonPtr(), nodes, keyset);
    const std::vector<std::string> keys(keyset.begin(), keyset.end());
    const JsonPtr at = nodes[pick(nodes.size())];
    const std::string where = at.to_string().empty() ? "/" : at.to_string();
    switch (pick(7)) {
      case 0:  // delete
        if (at.empty()) return "noop";
        erase(j, at);
        return "delete " + where;
      case 1: {  // replace by an odd value
        const nlohmann::json v = odd_value();
        j[at] = v;
        return "replace " + where + " by " + v.dump().substr(0, 60);
      }
      case 2: {  // duplicate array elements
        nlohmann::json& node = j[at];
        if (!node.is_array() || node.empty()) return "noop";
        const nlohmann::json e = node[pick(node.size())];
        const std::size_t copies = 1 + pick(3);
        for (std::size_t c = 0; c < copies; ++c) node.push_back(e);
        return "duplicate an element of " + where;
      }
      case 3: {  // rename a key (to a typo or to a key from elsewhere in the file)
        if (at.empty() || !j[at.parent_pointer()].is_object()) return "noop";
        const std::string old = at.back();
        std::string now = pick(2) ? keys[pick(keys.size())] : old + "_";
        if (pick(3) == 0 && old.size() > 1) now = old.substr(0, old.size() - 1);
        nlohmann::json& parent = j[at.parent_pointer()];
        nlohmann::json v = parent[old];
        parent.erase(old);
        parent[now] = v;
        return "rename " + where + " to " + now;
      }
      case 4: {  // move a copy of another subtree here
        const JsonPtr from = nodes[pick(nodes.size())];
        const nlohmann::json v = j[from];
        j[at] = v;
        return "copy " + from.to_string() + " to " + where;
      }
      case 5: {  // scale / negate a number
        nlohmann::json& node = j[at];
        if (!node.is_number()) return "noop";
        const double x = node.get<double>();
        const double f = std::pow(10.0, static_cast<double>(static_cast<int>(pick(25)) - 12));
        if (pick(4) == 0)
          node = -x;
        else if (node.is_number_integer() && pick(2))
          node = static_cast<std::int64_t>(std::clamp(x * static_cast<double>(pick(1000)), -9e18, 9e18));
        else
          node = x * f;
        return "scale " + where + " to " + node.dump();
      }
      default: {  // string value from the vocabulary of names
        static const std::vector<std::string> words = {"lattice", "deposit",       "fill",    "relax", "dynamics", "table",    "lognormal",
                                                       "uniform", "cylinder",      "plane",   "box",   "velocity", "pressure", "fixed",
                                                       "volume",  "hertz_mindlin", "gravity", "",      "floor",    "die",      ".",
                                                       "/",       "missing.h5"};
        const std::string w = words[pick(words.size())];
        j[at] = w;
        return "set " + where + " to \"" + w + "\"";
      }
    }
  }

  std::size_t pick(std::size_t n) { return static_cast<std::size_t>(rng_() % n); }

  /// One mutation of the extended set (the seven of mutate() or one of the additions above).
  std::string mutate_extended(nlohmann::json& j) {
    if (pick(2) == 0) return mutate(j);
    std::vector<JsonPtr> nodes;
    std::set<std::string> keyset;
    collect(j, JsonPtr(), nodes, keyset);
    const JsonPtr at = nodes[pick(nodes.size())];
    const std::string where = at.to_string().empty() ? "/" : at.to_string();
    switch (pick(6)) {
      case 0: {  // huge array
        // 100000 numbers, or 1000 copies of the subtree (100000 copies of a stage are a valid
        // but slow scene of 100000 stages, not a fuzzing target).
        nlohmann::json a = nlohmann::json::array();
        const bool numbers = pick(2) == 0;
        const std::size_t n = numbers ? 100000 : 1000;
        const nlohmann::json e = numbers ? nlohmann::json(1.0) : nlohmann::json(j[at]);
        for (std::size_t k = 0; k < n; ++k) a.push_back(e);
        j[at] = std::move(a);
        return "replace " + where + " by an array of " + std::to_string(n) + " copies";
      }
      case 1: {  // strings that look like numbers
        static const char* texts[] = {"NaN", "nan",  "-nan",  "Infinity", "-Infinity", "inf",
                                      "-0",  "0x10", "1e999", "-1e999",   "1e-400",    "18446744073709551616",
                                      " 1",  "1 ",   "+1",    "1,5",      "0.5.5"};
        const std::string t = texts[pick(sizeof texts / sizeof *texts)];
        j[at] = t;
        return "set " + where + " to the string \"" + t + "\"";
      }
      case 2: {  // file names where files are named
        static const char* keys[] = {"$include", "csv", "from_snapshot", "size_distribution.csv", "file", "table"};
        static const char* files[] = {"/dev/zero", "/dev/null", "/", ".", "..", "missing.json", "missing.h5", "nested/missing.csv", ""};
        const std::string k = keys[pick(6)];
        std::string f = files[pick(9)];
        if (pick(10) == 0) f = std::string(5000, 'n');
        nlohmann::json& node = j[at];
        if (node.is_object())
          node[k] = f;
        else if (!at.empty() && j[at.parent_pointer()].is_object())
          j[at.parent_pointer()][k] = f;
        else
          return "noop";
        return "set key " + k + " beside " + where + " to \"" + f.substr(0, 40) + "\"";
      }
      case 3: {  // wrap a value in an array or an object
        nlohmann::json v = j[at];
        if (pick(2))
          j[at] = nlohmann::json::array({v});
        else
          j[at] = nlohmann::json{{"value", v}};
        return "wrap " + where;
      }
      case 4: {  // swap two subtrees (when neither contains the other)
        const JsonPtr other = nodes[pick(nodes.size())];
        const std::string a = at.to_string(), b = other.to_string();
        if (a.rfind(b, 0) == 0 || b.rfind(a, 0) == 0) return "noop";
        nlohmann::json x = j[at], y = j[other];
        j[at] = y;
        j[other] = x;
        return "swap " + where + " and " + b;
      }
      default: {  // copy every key of another object into this one
        nlohmann::json& node = j[at];
        const JsonPtr from = nodes[pick(nodes.size())];
        const nlohmann::json src = j[from];
        if (!node.is_object() || !src.is_object()) return "noop";
        for (auto it = src.begin(); it != src.end(); ++it) node[it.key()] = it.value();
        return "merge the keys of " + from.to_string() + " into " + where;
      }
    }
  }

 private:
  nlohmann::json odd_value() {
    switch (pick(22)) {
      case 0:
        return "x";
      case 1:
        return "";
      case 2:
        return true;
      case 3:
        return nullptr;
      case 4:
        return 0;
      case 5:
        return -1;
      case 6:
        return 1e308;
      case 7:
        return -1e308;
      case 8:
        return std::numeric_limits<double>::infinity();
      case 9:
        return std::numeric_limits<double>::quiet_NaN();
      case 10:
        return std::numeric_limits<std::int64_t>::max();
      case 11:
        return std::numeric_limits<std::uint64_t>::max();
      case 12:
        return std::numeric_limits<std::int64_t>::min();
      case 13:
        return 4.9e-324;
      case 14:
        return nlohmann::json::array();
      case 15:
        return nlohmann::json::object();
      case 16:
        return nlohmann::json::array({1, 2, 3});
      case 17:
        return nlohmann::json::array({std::nan(""), 1e308, -1});
      case 18: {  // deeply nested object (within or beyond the loader's depth limit of 32)
        nlohmann::json v = 1;
        const int depth = pick(2) ? 20 : 200;
        for (int d = 0; d < depth; ++d) v = nlohmann::json{{"a", v}};
        return v;
      }
      case 19: {  // deeply nested array
        nlohmann::json v = nlohmann::json::array();
        const int depth = pick(2) ? 20 : 200;
        for (int d = 0; d < depth; ++d) v = nlohmann::json::array({v});
        return v;
      }
      case 20:
        return std::string(10000, 'z');
      default:
        return 0.5;
    }
  }
  void erase(nlohmann::json& j, const JsonPtr& at) {
    nlohmann::json& parent = j[at.parent_pointer()];
    if (parent.is_object())
      parent.erase(at.back());
    else
      parent.erase(static_cast<std::size_t>(std::stoul(at.back())));
  }
  std::mt19937_64 rng_;
};

}  // namespace sparkdem::test
