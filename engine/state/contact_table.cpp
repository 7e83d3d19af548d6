#include "engine/state/contact_table.hpp"

#include <algorithm>

#include "engine/core/error.hpp"

namespace sparkdem {

namespace {
inline std::uint64_t key(Id a, Id b) { return (static_cast<std::uint64_t>(a) << 32) ^ static_cast<std::uint64_t>(b); }
}  // namespace

void ContactTable::rebuild(const std::vector<std::array<Index, 2>>& pairs, const std::vector<Id>& ids,
                           std::size_t n_particles) {
  const std::size_t w = state_names_.size();
  std::unordered_map<std::uint64_t, std::size_t> old;
  if (w > 0) {
    old.reserve(size() * 2);
    for (std::size_t r = 0; r < size(); ++r) old.emplace(key(id_i_[r], id_j_[r]), r);
  }
  std::vector<Index> ni(pairs.size()), nj(pairs.size());
  std::vector<Id> nidi(pairs.size()), nidj(pairs.size());
  std::vector<double> nstate(pairs.size() * w, 0.0);
  for (std::size_t r = 0; r < pairs.size(); ++r) {
    Index a = pairs[r][0], b = pairs[r][1];
    if (ids[a] > ids[b]) std::swap(a, b);
    ni[r] = a; nj[r] = b; nidi[r] = ids[a]; nidj[r] = ids[b];
    if (w > 0) {
      auto it = old.find(key(ids[a], ids[b]));
      if (it != old.end()) std::copy_n(state_.begin() + it->second * w, w, nstate.begin() + r * w);
    }
  }
  i_.swap(ni); j_.swap(nj); id_i_.swap(nidi); id_j_.swap(nidj); state_.swap(nstate);
  force_.assign(size(), Vec3::Zero());
  torque_i_.assign(size(), Vec3::Zero());
  torque_j_.assign(size(), Vec3::Zero());
  overlap_.assign(size(), 0.0);
  build_incidence(n_particles);
}

void ContactTable::remap_after_permutation(const std::vector<Id>& ids) {
  std::unordered_map<Id, Index> local;
  local.reserve(ids.size() * 2);
  for (std::size_t k = 0; k < ids.size(); ++k) local.emplace(ids[k], static_cast<Index>(k));
  for (std::size_t r = 0; r < size(); ++r) {
    i_[r] = local.at(id_i_[r]);
    j_[r] = local.at(id_j_[r]);
  }
  build_incidence(ids.size());
}

void ContactTable::build_incidence(std::size_t n) {
  inc_start_.assign(n + 1, 0);
  for (std::size_t r = 0; r < size(); ++r) { ++inc_start_[i_[r] + 1]; ++inc_start_[j_[r] + 1]; }
  for (std::size_t p = 0; p < n; ++p) inc_start_[p + 1] += inc_start_[p];
  inc_row_.assign(inc_start_[n], 0);
  std::vector<std::int64_t> fill(inc_start_.begin(), inc_start_.end() - 1);
  for (std::size_t r = 0; r < size(); ++r) {
    inc_row_[fill[i_[r]]++] = static_cast<std::int64_t>(r);
    inc_row_[fill[j_[r]]++] = ~static_cast<std::int64_t>(r);
  }
}

void ContactTable::gather(std::vector<Vec3>& force, std::vector<Vec3>& torque) const {
  const std::int64_t n = static_cast<std::int64_t>(force.size());
#pragma omp parallel for schedule(static)
  for (std::int64_t p = 0; p < n; ++p) {
    Vec3 f = Vec3::Zero(), t = Vec3::Zero();
    for (std::int64_t k = inc_start_[p]; k < inc_start_[p + 1]; ++k) {
      const std::int64_t code = inc_row_[k];
      if (code >= 0) { f += force_[code]; t += torque_i_[code]; }
      else { f -= force_[~code]; t += torque_j_[~code]; }
    }
    force[p] += f;
    torque[p] += t;
  }
}

void ContactTable::visit(Archive& ar, const std::string& prefix) {
  std::vector<std::int64_t> a(id_i_.begin(), id_i_.end()), b(id_j_.begin(), id_j_.end());
  ar.visit(prefix + "/id_i", a);
  ar.visit(prefix + "/id_j", b);
  ar.visit(prefix + "/i", i_);
  ar.visit(prefix + "/j", j_);
  std::string names;
  for (const auto& n : state_names_) names += n + "\n";
  ar.visit(prefix + "/state_columns", names);
  if (ar.reading()) {
    state_names_.clear();
    std::string cur;
    for (char c : names) {
      if (c == '\n') { state_names_.push_back(cur); cur.clear(); } else cur += c;
    }
  }
  ar.visit(prefix + "/state", state_, std::max(1, state_width()));
  if (ar.reading()) {
    id_i_.assign(a.begin(), a.end());
    id_j_.assign(b.begin(), b.end());
    if (state_.size() != size() * state_names_.size())
      throw SetupError("checkpoint contact state has " + std::to_string(state_.size()) + " values, expected " +
                       std::to_string(size() * state_names_.size()) + " (different contact law?)");
    force_.assign(size(), Vec3::Zero());
    torque_i_.assign(size(), Vec3::Zero());
    torque_j_.assign(size(), Vec3::Zero());
    overlap_.assign(size(), 0.0);
  }
  // Overlaps of the last force pass: the built-in monitors (contacts, max_overlap_ratio) read
  // them, and a resumed stage checks its `until` conditions before its first force pass.
  if (!ar.reading() || ar.has(prefix + "/overlap")) ar.visit(prefix + "/overlap", overlap_);
  if (overlap_.size() != size())
    throw SetupError("checkpoint contact overlaps have " + std::to_string(overlap_.size()) + " rows, expected " +
                     std::to_string(size()));
  // Forces of the last force pass: the frame a resumed stage writes before its first force pass
  // (a checkpoint at the stage's last step) reports them. The torques are only read by the force
  // pass that recomputes them, so they are not stored.
  if (!ar.reading() || ar.has(prefix + "/force")) ar.visit(prefix + "/force", force_);
  if (force_.size() != size())
    throw SetupError("checkpoint contact forces have " + std::to_string(force_.size()) + " rows, expected " +
                     std::to_string(size()));
}

}  // namespace sparkdem
