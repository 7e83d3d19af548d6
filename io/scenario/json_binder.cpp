#include "io/scenario/json_binder.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace sparkdem::io {

namespace {

std::size_t levenshtein(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string num(double x) {
  std::ostringstream os;
  os.precision(10);
  os << x;
  return os.str();
}

std::string range_text(const ParamInfo& p) {
  std::string s;
  if (p.min) s += (p.min_exclusive ? "> " : ">= ") + num(*p.min);
  if (p.max) s += std::string(s.empty() ? "" : " and ") + (p.max_exclusive ? "< " : "<= ") + num(*p.max);
  return s;
}

/// Check one value against its ParamInfo; returns monostate on error.
ParamValue convert(const json& v, const ParamInfo& p, const std::string& path, std::vector<Diagnostic>& errors) {
  auto wrong = [&]() {
    errors.push_back({path, std::string("expected ") + kind_name(p.kind) + ", found " + describe(v)});
    return ParamValue{};
  };
  auto check_range = [&](double x, const std::string& at) {
    if (!std::isfinite(x)) {
      errors.push_back({at, "expected a finite number, found " + num(x)});
      return false;
    }
    bool ok = true;
    if (p.min && (p.min_exclusive ? !(x > *p.min) : !(x >= *p.min))) ok = false;
    if (p.max && (p.max_exclusive ? !(x < *p.max) : !(x <= *p.max))) ok = false;
    if (!ok)
      errors.push_back({at, "expected a value " + range_text(p) + (p.unit.empty() ? "" : " [" + p.unit + "]") + ", found " + num(x)});
    return ok;
  };
  switch (p.kind) {
    case ParamKind::Real:
      if (!v.is_number()) return wrong();
      if (!check_range(v.get<double>(), path)) return {};
      return v.get<double>();
    case ParamKind::Integer: {
      if (!v.is_number_integer() &&
          !(v.is_number_float() && std::floor(v.get<double>()) == v.get<double>() && std::abs(v.get<double>()) < 9e15))
        return wrong();
      const auto x = v.is_number_integer() ? v.get<std::int64_t>() : static_cast<std::int64_t>(v.get<double>());
      if (!check_range(static_cast<double>(x), path)) return {};
      return x;
    }
    case ParamKind::Boolean:
      if (!v.is_boolean()) return wrong();
      return v.get<bool>();
    case ParamKind::Text: {
      if (!v.is_string()) return wrong();
      const auto s = v.get<std::string>();
      if (!p.choices.empty() && std::find(p.choices.begin(), p.choices.end(), s) == p.choices.end()) {
        std::string list;
        for (const auto& c : p.choices) list += (list.empty() ? "" : ", ") + ("\"" + c + "\"");
        const auto dym = did_you_mean(s, p.choices);
        errors.push_back(
            {path, "expected one of " + list + ", found \"" + s + "\"" + (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
        return {};
      }
      return s;
    }
    case ParamKind::RealList:
    case ParamKind::Vec3: {
      if (!v.is_array()) return wrong();
      if (p.kind == ParamKind::Vec3 && v.size() != 3) {
        errors.push_back({path, "expected an array of 3 numbers, found an array of " + std::to_string(v.size())});
        return {};
      }
      std::vector<double> out;
      bool ok = true;
      for (std::size_t k = 0; k < v.size(); ++k) {
        if (!v[k].is_number()) {
          errors.push_back({path + "/" + std::to_string(k), "expected a number, found " + describe(v[k])});
          ok = false;
          continue;
        }
        if (p.kind == ParamKind::RealList && !check_range(v[k].get<double>(), path + "/" + std::to_string(k))) ok = false;
        if (p.kind == ParamKind::Vec3 && !std::isfinite(v[k].get<double>())) {
          errors.push_back({path + "/" + std::to_string(k), "expected a finite number"});
          ok = false;
        }
        out.push_back(v[k].get<double>());
      }
      if (!ok) return {};
      return out;
    }
  }
  return {};
}

void bind_level(const json& obj, const Spec& spec, const std::string& prefix, const std::string& path, ParamValues& out,
                std::vector<Diagnostic>& errors, const std::set<std::string>& extra) {
  // Keys known at this level: plain names and group names.
  std::vector<std::string> known;
  std::set<std::string> groups;
  for (const auto& p : spec.params) {
    if (p.name.rfind(prefix, 0) != 0) continue;
    const std::string rest = p.name.substr(prefix.size());
    const auto dot = rest.find('.');
    if (dot == std::string::npos)
      known.push_back(rest);
    else {
      groups.insert(rest.substr(0, dot));
      known.push_back(rest.substr(0, dot));
    }
  }
  std::vector<std::string> all = known;
  all.insert(all.end(), extra.begin(), extra.end());
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    const std::string key = it.key();
    if (std::find(all.begin(), all.end(), key) != all.end()) continue;
    if (prefix.empty()) {
      const auto gone = std::find_if(spec.retired.begin(), spec.retired.end(), [&](const auto& r) { return r.first == key; });
      if (gone != spec.retired.end()) {
        errors.push_back({path + "/" + key, "\"" + key + "\" is no longer a key of '" + spec.name + "': " + gone->second});
        continue;
      }
    }
    const auto dym = did_you_mean(key, all);
    errors.push_back({path + "/" + key, "unknown key \"" + key + "\" in " + (spec.name.empty() ? "this object" : "'" + spec.name + "'") +
                                            (dym.empty() ? "" : " (did you mean \"" + dym + "\"?)")});
  }
  for (const auto& p : spec.params) {
    if (p.name.rfind(prefix, 0) != 0) continue;
    const std::string rest = p.name.substr(prefix.size());
    if (rest.find('.') != std::string::npos) continue;
    if (obj.contains(rest)) {
      ParamValue v = convert(obj.at(rest), p, path + "/" + rest, errors);
      if (!std::holds_alternative<std::monostate>(v)) out[p.name] = v;
    } else if (p.required) {
      errors.push_back({path + "/" + rest, std::string("missing required key \"") + rest + "\" (" + kind_name(p.kind) +
                                               (p.unit.empty() ? "" : " [" + p.unit + "]") + ": " + p.doc + ")"});
    } else if (!std::holds_alternative<std::monostate>(p.default_value)) {
      out[p.name] = p.default_value;
    }
  }
  for (const auto& g : groups) {
    const json sub = obj.contains(g) ? obj.at(g) : json::object();
    if (!sub.is_object()) {
      errors.push_back({path + "/" + g, "expected an object, found " + describe(sub)});
      continue;
    }
    bind_level(sub, spec, prefix + g + ".", path + "/" + g, out, errors, {});
  }
}

}  // namespace

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t bestd = 4;
  for (const auto& c : candidates) {
    // The edit distance is at least the length difference: skip candidates that cannot beat the
    // best so far (a 60-character typo against 700 columns cost 0.2 s of Levenshtein tables).
    const std::size_t diff = word.size() > c.size() ? word.size() - c.size() : c.size() - word.size();
    if (diff >= bestd) continue;
    const std::size_t d = levenshtein(word, c);
    if (d < bestd) {
      bestd = d;
      best = c;
    }
  }
  return bestd <= std::max<std::size_t>(1, std::min<std::size_t>(3, word.size() / 2)) ? best : "";
}

std::string suggest(const std::string& word, const std::vector<std::string>& candidates) {
  const auto dym = did_you_mean(word, candidates);
  return dym.empty() ? "" : " (did you mean \"" + dym + "\"?)";
}

std::string describe(const json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number()) return v.dump();
  if (v.is_string()) return "\"" + v.get<std::string>() + "\" (a string)";
  if (v.is_array()) return "an array of " + std::to_string(v.size());
  return "an object";
}

ParamValues bind_params(const json& obj, const Spec& spec, const std::string& path, std::vector<Diagnostic>& errors,
                        const std::set<std::string>& extra_keys) {
  ParamValues out;
  if (!obj.is_object()) {
    errors.push_back({path, "expected an object, found " + describe(obj)});
    return out;
  }
  bind_level(obj, spec, "", path, out, errors, extra_keys);
  return out;
}

json to_json(const ParamValues& values, const Spec& spec) {
  json out = json::object();
  for (const auto& p : spec.params) {
    auto it = values.find(p.name);
    if (it == values.end()) continue;
    json* node = &out;
    std::string name = p.name;
    for (auto dot = name.find('.'); dot != std::string::npos; dot = name.find('.')) {
      node = &(*node)[name.substr(0, dot)];
      name = name.substr(dot + 1);
    }
    std::visit(
        [&](const auto& x) {
          using T = std::decay_t<decltype(x)>;
          if constexpr (!std::is_same_v<T, std::monostate>) (*node)[name] = x;
        },
        it->second);
  }
  return out;
}

json spec_to_json(const Spec& spec) {
  json j;
  j["name"] = spec.name;
  j["category"] = spec.category;
  j["doc"] = spec.doc;
  j["params"] = json::array();
  for (const auto& p : spec.params) {
    json q;
    q["name"] = p.name;
    q["type"] = kind_name(p.kind);
    if (!p.unit.empty()) q["unit"] = p.unit;
    q["doc"] = p.doc;
    if (p.required) q["required"] = true;
    if (p.min) q[p.min_exclusive ? "exclusive_minimum" : "minimum"] = *p.min;
    if (p.max) q[p.max_exclusive ? "exclusive_maximum" : "maximum"] = *p.max;
    if (!p.choices.empty()) q["choices"] = p.choices;
    std::visit(
        [&](const auto& x) {
          using T = std::decay_t<decltype(x)>;
          if constexpr (std::is_same_v<T, double>) {
            if (std::isfinite(x))
              q["default"] = x;
            else
              q["default"] = "inf";
          } else if constexpr (!std::is_same_v<T, std::monostate>)
            q["default"] = x;
        },
        p.default_value);
    j["params"].push_back(q);
  }
  return j;
}

double get_real(const ParamValues& v, const std::string& k) { return std::get<double>(v.at(k)); }
std::int64_t get_int(const ParamValues& v, const std::string& k) { return std::get<std::int64_t>(v.at(k)); }
bool get_bool(const ParamValues& v, const std::string& k) { return std::get<bool>(v.at(k)); }
std::string get_text(const ParamValues& v, const std::string& k) { return std::get<std::string>(v.at(k)); }
std::vector<double> get_list(const ParamValues& v, const std::string& k) { return std::get<std::vector<double>>(v.at(k)); }

}  // namespace sparkdem::io
