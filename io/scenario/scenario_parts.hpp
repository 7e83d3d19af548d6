#pragma once
/// Pieces of the scenario loader shared by the scenario level (scenario.cpp) and the stage facets
/// (stage_facets.cpp): binding a spec, naming registry entries, walls, wall motions and module
/// clocks. Every function appends problems to `errors` with their JSON pointer (nothing throws).
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "engine/model/registry.hpp"
#include "engine/simulation.hpp"
#include "io/scenario/json_binder.hpp"

namespace sparkdem::io {

using nlohmann::json;

/// Bind `obj` against the spec of `ps` and build its aggregate; `resolved` gets the bound values
/// (defaults filled in). Values that did not bind keep the aggregate's defaults.
template <class P>
P build(const ParamSpec<P>& ps, const json& obj, const std::string& path, std::vector<Diagnostic>& errors, json& resolved,
        const std::set<std::string>& extra = {}) {
  const ParamValues v = bind_params(obj, ps.spec(), path, errors, extra);
  resolved = to_json(v, ps.spec());
  return ps.build(v);
}

/// The keys of a map, in its order.
std::vector<std::string> names_of(const auto& map) {
  std::vector<std::string> n;
  for (const auto& [k, v] : map) n.push_back(k);
  return n;
}

/// "a, b, c".
std::string list_names(const std::vector<std::string>& n);

/// An object {"law": name, "params": {...}} (plus `extra` keys, checked by the caller) naming an
/// entry of a registry table; `what` is "contact law" or "bond law".
template <class T>
std::unique_ptr<T> make_named(const json& c, const std::map<std::string, RegistryEntry<T>>& table, const std::string& what,
                              const std::string& path, std::vector<Diagnostic>& errors, json& resolved,
                              const std::set<std::string>& extra = {}) {
  if (!c.is_object()) {
    errors.push_back({path, "expected an object {\"law\": ..., \"params\": {...}}, found " + describe(c)});
    return nullptr;
  }
  for (auto it = c.begin(); it != c.end(); ++it)
    if (it.key() != "law" && it.key() != "params" && !extra.count(it.key()))
      errors.push_back({path + "/" + it.key(), "unknown key \"" + it.key() + "\" (expected \"law\" and \"params\")"});
  if (!c.contains("law") || !c["law"].is_string()) {
    errors.push_back({path + "/law", "missing or non-string " + what + " name; registered: " + list_names(names_of(table))});
    return nullptr;
  }
  const auto name = c["law"].get<std::string>();
  auto it = table.find(name);
  if (it == table.end()) {
    errors.push_back({path + "/law", "unknown " + what + " \"" + name + "\"" + suggest(name, names_of(table)) +
                                         "; registered: " + list_names(names_of(table))});
    return nullptr;
  }
  const std::size_t before = errors.size();
  const ParamValues v = bind_params(c.value("params", json::object()), it->second.spec, path + "/params", errors);
  resolved = {{"law", name}, {"params", to_json(v, it->second.spec)}};
  if (errors.size() != before) return nullptr;
  return it->second.make(v);
}

std::unique_ptr<ContactModel> make_law(const json& c, const Registry& reg, const std::string& path, std::vector<Diagnostic>& errors,
                                       json& resolved);

/// Specs of a wall, a wall motion and a module clock (for binding and `sparkdem schema`).
Spec wall_schema();
Spec motion_schema();
Spec clock_schema();

/// A wall {"name", "type": plane|cylinder, ...}.
Wall make_wall(const json& w, const std::string& path, std::vector<Diagnostic>& errors, json& resolved);
/// A wall motion {"type": fixed|velocity|table|pressure, ...}.
WallMotion make_motion(const json& m, const std::string& path, std::vector<Diagnostic>& errors, json& resolved);
/// A module clock {"kind", "n", and for on_event the trigger conditions}.
Clock make_clock(const json& j, const std::string& path, std::vector<Diagnostic>& errors, json& resolved);

}  // namespace sparkdem::io
