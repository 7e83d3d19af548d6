/// Deterministic mutation fuzzing of the scenario loader (in process, no simulation).
///
/// Starting from every configs/*.json and tests/scenario/data/*.json, 500 seeded random
/// mutations each (delete a key or element, replace a value by another type / NaN / inf / huge /
/// negative / empty / deeply nested value, duplicate array elements, rename keys, move subtrees,
/// scale numbers, truncate the text) are fed to io::load_scenario.
/// Invariant: loading either succeeds or throws one of the typed errors (json parse error for
/// truncated text, ConfigError, SetupError) within one second; any other exception is a bug.
#include <catch2/catch.hpp>

#include "support/mock_modules.hpp"
#include "support/scratch.hpp"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/registry.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Ptr = json::json_pointer;

/// Every registered law, module and generator plus the test mocks (scenes in tests/scenario/data
/// may use the mock modules of the contract tests).
const sparkdem::Registry& registry() {
  static const sparkdem::Registry reg = sparkdem::test::registry_with_mocks();
  return reg;
}

std::vector<fs::path> seed_files() {
  std::vector<fs::path> files;
  for (const char* dir : {"configs", "tests/scenario/data"})
    for (const auto& e : fs::directory_iterator(fs::path(SPARKDEM_SOURCE_DIR) / dir))
      if (e.path().extension() == ".json") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

void collect(const json& j, const Ptr& p, std::vector<Ptr>& nodes, std::set<std::string>& keys) {
  nodes.push_back(p);
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) {
      keys.insert(it.key());
      collect(it.value(), p / it.key(), nodes, keys);
    }
  else if (j.is_array())
    for (std::size_t k = 0; k < j.size(); ++k) collect(j[k], p / k, nodes, keys);
}

class Mutator {
 public:
  explicit Mutator(std::uint64_t seed) : rng_(seed) {}

  /// One random mutation of `j` (in place); returns a description for failure reports.
  std::string mutate(json& j) {
    std::vector<Ptr> nodes;
    std::set<std::string> keyset;
    collect(j, Ptr(), nodes, keyset);
    const std::vector<std::string> keys(keyset.begin(), keyset.end());
    const Ptr at = nodes[pick(nodes.size())];
    const std::string where = at.to_string().empty() ? "/" : at.to_string();
    switch (pick(7)) {
      case 0:  // delete
        if (at.empty()) return "noop";
        erase(j, at);
        return "delete " + where;
      case 1: {  // replace by an odd value
        const json v = odd_value();
        j[at] = v;
        return "replace " + where + " by " + v.dump().substr(0, 60);
      }
      case 2: {  // duplicate array elements
        json& node = j[at];
        if (!node.is_array() || node.empty()) return "noop";
        const json e = node[pick(node.size())];
        const std::size_t copies = 1 + pick(3);
        for (std::size_t c = 0; c < copies; ++c) node.push_back(e);
        return "duplicate an element of " + where;
      }
      case 3: {  // rename a key (to a typo or to a key from elsewhere in the file)
        if (at.empty() || !j[at.parent_pointer()].is_object()) return "noop";
        const std::string old = at.back();
        std::string now = pick(2) ? keys[pick(keys.size())] : old + "_";
        if (pick(3) == 0 && old.size() > 1) now = old.substr(0, old.size() - 1);
        json& parent = j[at.parent_pointer()];
        json v = parent[old];
        parent.erase(old);
        parent[now] = v;
        return "rename " + where + " to " + now;
      }
      case 4: {  // move a copy of another subtree here
        const Ptr from = nodes[pick(nodes.size())];
        const json v = j[from];
        j[at] = v;
        return "copy " + from.to_string() + " to " + where;
      }
      case 5: {  // scale / negate a number
        json& node = j[at];
        if (!node.is_number()) return "noop";
        const double x = node.get<double>();
        const double f = std::pow(10.0, static_cast<double>(static_cast<int>(pick(25)) - 12));
        if (pick(4) == 0) node = -x;
        else if (node.is_number_integer() && pick(2)) node = static_cast<std::int64_t>(std::clamp(x * static_cast<double>(pick(1000)), -9e18, 9e18));
        else node = x * f;
        return "scale " + where + " to " + node.dump();
      }
      default: {  // string value from the vocabulary of names
        static const std::vector<std::string> words = {"lattice", "deposit", "fill", "relax", "dynamics", "table",
                                                       "lognormal", "uniform", "cylinder", "plane", "box", "velocity",
                                                       "pressure", "fixed", "volume", "hertz_mindlin", "gravity", "",
                                                       "floor", "die", ".", "/", "missing.h5"};
        const std::string w = words[pick(words.size())];
        j[at] = w;
        return "set " + where + " to \"" + w + "\"";
      }
    }
  }

  std::size_t pick(std::size_t n) { return static_cast<std::size_t>(rng_() % n); }

 private:
  json odd_value() {
    switch (pick(22)) {
      case 0: return "x";
      case 1: return "";
      case 2: return true;
      case 3: return nullptr;
      case 4: return 0;
      case 5: return -1;
      case 6: return 1e308;
      case 7: return -1e308;
      case 8: return std::numeric_limits<double>::infinity();
      case 9: return std::numeric_limits<double>::quiet_NaN();
      case 10: return std::numeric_limits<std::int64_t>::max();
      case 11: return std::numeric_limits<std::uint64_t>::max();
      case 12: return std::numeric_limits<std::int64_t>::min();
      case 13: return 4.9e-324;
      case 14: return json::array();
      case 15: return json::object();
      case 16: return json::array({1, 2, 3});
      case 17: return json::array({std::nan(""), 1e308, -1});
      case 18: {  // deeply nested object (within or beyond the loader's depth limit of 32)
        json v = 1;
        const int depth = pick(2) ? 20 : 200;
        for (int d = 0; d < depth; ++d) v = json{{"a", v}};
        return v;
      }
      case 19: {  // deeply nested array
        json v = json::array();
        const int depth = pick(2) ? 20 : 200;
        for (int d = 0; d < depth; ++d) v = json::array({v});
        return v;
      }
      case 20: return std::string(10000, 'z');
      default: return 0.5;
    }
  }
  void erase(json& j, const Ptr& at) {
    json& parent = j[at.parent_pointer()];
    if (parent.is_object()) parent.erase(at.back());
    else parent.erase(static_cast<std::size_t>(std::stoul(at.back())));
  }
  std::mt19937_64 rng_;
};

}  // namespace

TEST_CASE("the scenario loader survives 500 seeded mutations of every example scene", "[fuzz][scenario]") {
  const auto files = seed_files();
  REQUIRE(files.size() >= 3);
  // SPARKDEM_FUZZ_MUTATIONS / SPARKDEM_FUZZ_SEED override the count and seed for longer exploration.
  const int kMutations = std::getenv("SPARKDEM_FUZZ_MUTATIONS") ? std::atoi(std::getenv("SPARKDEM_FUZZ_MUTATIONS")) : 500;
  const std::uint64_t seed = std::getenv("SPARKDEM_FUZZ_SEED") ? std::strtoull(std::getenv("SPARKDEM_FUZZ_SEED"), nullptr, 10) : 0x5eed0000u;
  for (const auto& file : files) {
    INFO("seed file " << file.filename().string());
    std::ifstream in(file);
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    const json original = json::parse(text);
    // The unmutated scene loads (the mutations start from a valid scenario).
    CHECK_NOTHROW(sparkdem::io::load_scenario(original, registry(), file.parent_path()));

    Mutator mut(seed + std::hash<std::string>{}(file.filename().string()) % 1000);
    int accepted = 0, rejected = 0, unparsable = 0;
    for (int k = 0; k < kMutations; ++k) {
      json j = original;
      std::string what;
      bool parsed = true;
      if (mut.pick(10) == 0) {  // truncate the text
        const std::size_t cut = mut.pick(text.size());
        what = "truncate at byte " + std::to_string(cut);
        try {
          j = json::parse(text.substr(0, cut));
        } catch (const json::parse_error&) {
          parsed = false;
          ++unparsable;
        }
      } else {
        const std::size_t n = 1 + mut.pick(3);
        for (std::size_t q = 0; q < n; ++q) what += mut.mutate(j) + "; ";
      }
      if (!parsed) continue;
      const auto t0 = std::chrono::steady_clock::now();
      std::string failure;
      try {
        (void)sparkdem::io::load_scenario(j, registry(), file.parent_path());
        ++accepted;
      } catch (const sparkdem::ConfigError&) {
        ++rejected;
      } catch (const sparkdem::SetupError&) {
        ++rejected;
      } catch (const std::exception& e) {
        failure = std::string("untyped exception: ") + e.what();
      }
      const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (secs > 1.0) failure += " took " + std::to_string(secs) + " s";

      if (!failure.empty()) {
        INFO("mutation " << k << ": " << what << "\n" << failure);
        CHECK(failure.empty());
      }
    }
    // Most mutations must be caught: a loader that accepted everything would pass the loop above.
    CHECK(rejected > kMutations / 4);
    CHECK(accepted + rejected + unparsable == kMutations);
  }
}
