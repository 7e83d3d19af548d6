#pragma once
/// Binds JSON objects to parameter Specs: types, ranges, choices, required keys, unknown keys
/// (with a did-you-mean), nested objects for dotted names ("size_distribution.type" <->
/// {"size_distribution": {"type": ...}}). Every problem is appended to `errors` with its JSON
/// pointer; nothing throws, so all problems of a scenario are reported at once.
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "engine/core/error.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem::io {

using nlohmann::json;

/// Levenshtein-closest candidate within distance 3 (or ""), for "did you mean".
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

/// " (did you mean \"x\"?)" with the closest candidate, or "" when none is close: the suffix of a message.
std::string suggest(const std::string& word, const std::vector<std::string>& candidates);

/// Short description of a JSON value for messages: `"abc"` (string), `12.5` (number), `an object`.
std::string describe(const json& v);

/// Bind `obj` (must be an object) against `spec`. Keys listed in `extra_keys` are accepted and
/// left to the caller. Returns the values (defaults filled in) and appends diagnostics.
ParamValues bind_params(const json& obj, const Spec& spec, const std::string& path, std::vector<Diagnostic>& errors,
                        const std::set<std::string>& extra_keys = {});

/// The resolved JSON of bound values (defaults filled in), nested by dotted names.
json to_json(const ParamValues& values, const Spec& spec);

/// Spec as JSON (for `sparkdem schema`).
json spec_to_json(const Spec& spec);

/// Typed accessors on bound values (the spec guarantees presence when a default exists).
double get_real(const ParamValues& v, const std::string& k);
std::int64_t get_int(const ParamValues& v, const std::string& k);
bool get_bool(const ParamValues& v, const std::string& k);
std::string get_text(const ParamValues& v, const std::string& k);
std::vector<double> get_list(const ParamValues& v, const std::string& k);

}  // namespace sparkdem::io
