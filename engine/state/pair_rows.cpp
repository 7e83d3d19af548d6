#include "engine/state/pair_rows.hpp"

#include <algorithm>
#include <unordered_map>

#include "engine/core/error.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

int PairRows::column(const std::string& name) const {
  for (std::size_t k = 0; k < state_names_.size(); ++k)
    if (state_names_[k] == name) return static_cast<int>(k);
  return -1;
}

void PairRows::remap_after_permutation(const std::vector<Id>& ids) {
  std::unordered_map<Id, Index> local;
  local.reserve(ids.size() * 2);
  for (std::size_t k = 0; k < ids.size(); ++k) local.emplace(ids[k], static_cast<Index>(k));
  for (std::size_t r = 0; r < size(); ++r) {
    const auto a = local.find(id_i_[r]), b = local.find(id_j_[r]);
    if (a == local.end() || b == local.end())
      throw SetupError("pair (" + std::to_string(id_i_[r]) + ", " + std::to_string(id_j_[r]) +
                       ") refers to a particle id that does not exist");
    i_[r] = a->second;
    j_[r] = b->second;
  }
  build_incidence(ids.size());
}

void PairRows::keep_rows(const std::vector<char>& keep) {
  split_.threads = 0;
  const std::size_t w = state_names_.size(), n = size();
  const bool results = force_.size() == n, torques = results && torque_i_.size() == n && torque_j_.size() == n;
  std::size_t q = 0;
  for (std::size_t r = 0; r < n; ++r) {
    if (!keep[r]) continue;
    i_[q] = i_[r];
    j_[q] = j_[r];
    id_i_[q] = id_i_[r];
    id_j_[q] = id_j_[r];
    std::copy_n(state_.begin() + r * w, w, state_.begin() + q * w);
    if (results) force_[q] = force_[r];
    if (torques) {
      torque_i_[q] = torque_i_[r];
      torque_j_[q] = torque_j_[r];
    }
    ++q;
  }
  i_.resize(q);
  j_.resize(q);
  id_i_.resize(q);
  id_j_.resize(q);
  state_.resize(q * w);
  force_.resize(results ? q : 0);
  if (!results) force_.assign(q, Vec3::Zero());
  torque_i_.resize(torques ? q : 0);  // unsized torque rows stay so (torque_i(), torque_j())
  torque_j_.resize(torques ? q : 0);
}

void PairRows::copy_named_state(std::size_t r, const std::vector<std::string>& from_names, const double* from) {
  double* to = state(r);
  for (std::size_t a = 0; a < from_names.size(); ++a) {
    const int c = column(from_names[a]);
    if (c >= 0) to[c] = from[a];
  }
}

void PairRows::reset_results(std::size_t n_particles) {
  force_.assign(size(), Vec3::Zero());
  std::vector<Vec3>().swap(torque_i_);
  std::vector<Vec3>().swap(torque_j_);
  build_incidence(n_particles);
}

void PairRows::build_incidence(std::size_t n) {
  split_.threads = 0;
  inc_particles_ = n;
  inc_built_ = false;
  std::vector<std::int64_t>().swap(inc_row_);
}

void PairRows::ensure_incidence() const {
  if (inc_built_) return;
  sparkdem::build_incidence(
      inc_particles_, size(), [&](std::size_t r) { return i_[r]; }, [&](std::size_t r) { return j_[r]; }, inc_start_, inc_row_);
  inc_built_ = true;
}

void PairRows::gather_one(std::int64_t p, std::vector<Vec3>& force, std::vector<Vec3>& torque) const {
  Vec3 f = Vec3::Zero(), t = Vec3::Zero();
  const bool torques = torque_i_.size() == size() && torque_j_.size() == size();  // unsized: no pass filled them (zero)
  for (std::int64_t k = inc_start_[p]; k < inc_start_[p + 1]; ++k) {
    const std::int64_t code = inc_row_[k];
    if (code >= 0) {
      f += force_[code];
      if (torques) t += torque_i_[code];
    } else {
      f -= force_[~code];
      if (torques) t += torque_j_[~code];
    }
  }
  force[p] += f;
  torque[p] += t;
}

void PairRows::gather(std::vector<Vec3>& force, std::vector<Vec3>& torque) const {
  ensure_incidence();
  const std::int64_t n = static_cast<std::int64_t>(force.size());
  par::for_each(n, par::kLight, [&](std::int64_t p) { gather_one(p, force, torque); });
}

void PairRows::gather_particles(const std::vector<Index>& which, std::vector<Vec3>& force, std::vector<Vec3>& torque) const {
  ensure_incidence();
  const std::int64_t n = static_cast<std::int64_t>(which.size());
  par::for_each(n, par::kLight, [&](std::int64_t k) { gather_one(which[k], force, torque); });
}

const PairRows::RowSplit& PairRows::row_split(int threads, const std::function<bool(std::int64_t)>& heavy, double heavy_cost) const {
  if (split_.threads == threads && split_.heavy_cost == heavy_cost) return split_;
  ensure_incidence();
  const std::int64_t rows = static_cast<std::int64_t>(size()), n = static_cast<std::int64_t>(inc_start_.size()) - 1;
  split_.row_begin.resize(threads + 1);
  for (int t = 0; t <= threads; ++t) split_.row_begin[t] = rows * t / threads;
  if (heavy && threads > 1) {
    std::vector<double> cost(rows + 1, 0.0);  // cost[r] = summed cost of the rows before r
    for (std::int64_t r = 0; r < rows; ++r) cost[r + 1] = cost[r] + (heavy(r) ? heavy_cost : 1.0);
    for (int t = 1; t < threads; ++t)
      split_.row_begin[t] = std::lower_bound(cost.begin(), cost.end(), cost[rows] * t / threads) - cost.begin();
  }
  const auto range_of = [&](std::int64_t code) {
    const std::int64_t r = code >= 0 ? code : ~code;
    int t = 0;
    while (r >= split_.row_begin[t + 1]) ++t;
    return static_cast<std::int32_t>(t);
  };
  split_.owner.assign(std::max<std::int64_t>(n, 0), -1);
  split_.boundary.clear();
  for (std::int64_t p = 0; p < n; ++p) {
    if (inc_start_[p] == inc_start_[p + 1]) continue;
    // the incidence lists rows in increasing order: the first and last give the ranges touched
    const std::int32_t a = range_of(inc_row_[inc_start_[p]]), b = range_of(inc_row_[inc_start_[p + 1] - 1]);
    if (a == b)
      split_.owner[p] = a;
    else
      split_.boundary.push_back(static_cast<Index>(p));
  }
  split_.threads = threads;
  split_.heavy_cost = heavy_cost;
  return split_;
}

void PairRows::visit_rows(Archive& ar, const std::string& prefix, const std::string& what) {
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
      if (c == '\n') {
        state_names_.push_back(cur);
        cur.clear();
      } else
        cur += c;
    }
  }
  ar.visit(prefix + "/state", state_, std::max(1, state_width()));
  if (ar.reading()) {
    if (b.size() != a.size() || i_.size() != a.size() || j_.size() != a.size())
      throw SetupError("checkpoint " + what + " table is inconsistent: id_i, id_j, i, j have " + std::to_string(a.size()) + ", " +
                       std::to_string(b.size()) + ", " + std::to_string(i_.size()) + ", " + std::to_string(j_.size()) + " rows");
    id_i_.assign(a.begin(), a.end());
    id_j_.assign(b.begin(), b.end());
    if (state_.size() != size() * state_names_.size())
      throw SetupError("checkpoint " + what + " state has " + std::to_string(state_.size()) + " values, expected " +
                       std::to_string(size() * state_names_.size()) + " (different law?)");
    force_.assign(size(), Vec3::Zero());
    std::vector<Vec3>().swap(torque_i_);
    std::vector<Vec3>().swap(torque_j_);
  }
}

}  // namespace sparkdem
