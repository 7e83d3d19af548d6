#pragma once
/// Declarative parameter descriptions (deal.II add_parameter style). A law, module, stage or
/// wall describes its parameters once; io/ binds JSON to them (checking types, ranges and
/// unknown keys) and `sparkdem schema` prints them. The engine never sees JSON.
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace sparkdem {

enum class ParamKind { Real, Integer, Boolean, Text, RealList, Vec3 };

/// A bound value: Real -> double, Integer -> int64, Boolean -> bool, Text -> string,
/// RealList and Vec3 -> vector<double>.
using ParamValue = std::variant<std::monostate, double, std::int64_t, bool, std::string, std::vector<double>>;
using ParamValues = std::map<std::string, ParamValue>;

inline const char* kind_name(ParamKind k) {
  switch (k) {
    case ParamKind::Real:
      return "number";
    case ParamKind::Integer:
      return "integer";
    case ParamKind::Boolean:
      return "boolean";
    case ParamKind::Text:
      return "string";
    case ParamKind::RealList:
      return "array of numbers";
    case ParamKind::Vec3:
      return "array of 3 numbers";
  }
  return "?";
}

/// Description of one parameter.
struct ParamInfo {
  std::string name;
  ParamKind kind = ParamKind::Real;
  std::string unit;  ///< SI unit, "1" for dimensionless, "" for non-numbers
  std::string doc;
  bool required = false;
  std::optional<double> min, max;  ///< inclusive bounds unless *_exclusive
  bool min_exclusive = false, max_exclusive = false;
  std::vector<std::string> choices;  ///< allowed values of a Text parameter
  ParamValue default_value;          ///< monostate when there is no default
};

/// Spec of one named thing (a law, a module, a stage type, a wall shape, ...).
struct Spec {
  std::string name;
  std::string category;  ///< "contact_law", "module", "stage", "wall", "motion", ...
  std::string doc;
  std::vector<ParamInfo> params;
  /// Keys that no longer exist, each with the message that says what replaced it (the scenario
  /// loader refuses them with that message instead of "unknown key").
  std::vector<std::pair<std::string, std::string>> retired;
  const ParamInfo* find(const std::string& n) const {
    for (const auto& p : params)
      if (p.name == n) return &p;
    return nullptr;
  }
};

/// Chainable editor for one ParamInfo.
class ParamEditor {
 public:
  explicit ParamEditor(ParamInfo& p) : p_(p) {}
  ParamEditor& unit(std::string u) {
    p_.unit = std::move(u);
    return *this;
  }
  ParamEditor& doc(std::string d) {
    p_.doc = std::move(d);
    return *this;
  }
  ParamEditor& required() {
    p_.required = true;
    p_.default_value = std::monostate{};
    return *this;
  }
  ParamEditor& min(double v) {
    p_.min = v;
    return *this;
  }
  ParamEditor& max(double v) {
    p_.max = v;
    return *this;
  }
  ParamEditor& range(double lo, double hi) {
    p_.min = lo;
    p_.max = hi;
    return *this;
  }
  ParamEditor& positive() {
    p_.min = 0.0;
    p_.min_exclusive = true;
    return *this;
  }
  ParamEditor& nonnegative() {
    p_.min = 0.0;
    return *this;
  }
  ParamEditor& choices(std::vector<std::string> c) {
    p_.choices = std::move(c);
    return *this;
  }
  ParamEditor& no_default() {
    p_.default_value = std::monostate{};
    return *this;
  }
  /// Default differing from the member initialiser (a spec shared by several owners).
  ParamEditor& defaults_to(ParamValue v) {
    p_.default_value = std::move(v);
    return *this;
  }

 private:
  ParamInfo& p_;
};

/// Typed spec: maps parameters onto the members of a plain aggregate P. Defaults are
/// taken from P's default member initialisers.
template <class P>
class ParamSpec {
 public:
  ParamSpec(std::string name, std::string category, std::string doc) {
    spec_.name = std::move(name);
    spec_.category = std::move(category);
    spec_.doc = std::move(doc);
  }

  /// A key that was removed: scenarios that still give it are refused with `message` (which
  /// names the key to use instead).
  void retire(std::string name, std::string message) { spec_.retired.emplace_back(std::move(name), std::move(message)); }

  ParamEditor add(std::string name, double P::*m) {
    return add_impl(std::move(name), ParamKind::Real, ParamValue{P{}.*m}, [m](P& p, const ParamValue& v) { p.*m = std::get<double>(v); });
  }
  ParamEditor add(std::string name, std::int64_t P::*m) {
    return add_impl(std::move(name), ParamKind::Integer, ParamValue{P{}.*m},
                    [m](P& p, const ParamValue& v) { p.*m = std::get<std::int64_t>(v); });
  }
  ParamEditor add(std::string name, bool P::*m) {
    return add_impl(std::move(name), ParamKind::Boolean, ParamValue{P{}.*m}, [m](P& p, const ParamValue& v) { p.*m = std::get<bool>(v); });
  }
  ParamEditor add(std::string name, std::string P::*m) {
    return add_impl(std::move(name), ParamKind::Text, ParamValue{P{}.*m},
                    [m](P& p, const ParamValue& v) { p.*m = std::get<std::string>(v); });
  }
  ParamEditor add(std::string name, std::vector<double> P::*m) {
    return add_impl(std::move(name), ParamKind::RealList, ParamValue{P{}.*m},
                    [m](P& p, const ParamValue& v) { p.*m = std::get<std::vector<double>>(v); });
  }
  template <class V>
  ParamEditor add_vec3(std::string name, V P::*m) {
    const V d = P{}.*m;
    return add_impl(std::move(name), ParamKind::Vec3, ParamValue{std::vector<double>{d[0], d[1], d[2]}}, [m](P& p, const ParamValue& v) {
      const auto& x = std::get<std::vector<double>>(v);
      p.*m = V(x[0], x[1], x[2]);
    });
  }

  /// Embed the parameters of a nested aggregate M (member `outer` of P) under "prefix.<name>";
  /// in JSON they form a nested object {"prefix": {...}}.
  template <class M>
  void add_group(const std::string& prefix, M P::*outer, const ParamSpec<M>& inner) {
    for (std::size_t k = 0; k < inner.spec().params.size(); ++k) {
      ParamInfo info = inner.spec().params[k];
      info.name = prefix + "." + info.name;
      spec_.params.push_back(info);
      setters_.push_back([outer, inner, k](P& p, const ParamValue& v) { inner.set(k, p.*outer, v); });
    }
  }

  const Spec& spec() const { return spec_; }
  /// Apply value v to parameter number k of p.
  void set(std::size_t k, P& p, const ParamValue& v) const { setters_.at(k)(p, v); }

  /// Build P from already validated values (io checks kinds and ranges against spec()).
  P build(const ParamValues& values) const {
    P p{};
    for (std::size_t k = 0; k < spec_.params.size(); ++k) {
      auto it = values.find(spec_.params[k].name);
      if (it != values.end() && !std::holds_alternative<std::monostate>(it->second)) setters_[k](p, it->second);
    }
    return p;
  }

 private:
  ParamEditor add_impl(std::string name, ParamKind kind, ParamValue def, std::function<void(P&, const ParamValue&)> set) {
    ParamInfo info;
    info.name = std::move(name);
    info.kind = kind;
    info.default_value = std::move(def);
    spec_.params.push_back(std::move(info));
    setters_.push_back(std::move(set));
    return ParamEditor(spec_.params.back());
  }
  Spec spec_;
  std::vector<std::function<void(P&, const ParamValue&)>> setters_;
};

}  // namespace sparkdem
