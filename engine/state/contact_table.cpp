#include "engine/state/contact_table.hpp"

#include <algorithm>
#include <map>

#include "engine/core/error.hpp"
#include "engine/core/hash.hpp"

namespace sparkdem {

namespace {

/// The rows of a table by pair key, for the rebuild's look-ups: open addressing with linear
/// probing over a power-of-two array of at least twice the rows (16 bytes a slot, one allocation)
/// in place of a node-based map (one allocation a row, about 60 bytes a row).
class RowsByKey {
 public:
  explicit RowsByKey(std::size_t rows) {
    std::size_t cap = 16;
    while (cap < 2 * rows) cap *= 2;
    mask_ = cap - 1;
    slots_.assign(cap, {0, kNone});
  }
  /// Adds a row (a key already present keeps its first row).
  void insert(std::uint64_t key, std::size_t row) {
    std::size_t s = home(key);
    while (slots_[s].row != kNone && slots_[s].key != key) s = (s + 1) & mask_;
    if (slots_[s].row == kNone) slots_[s] = {key, row};
  }
  /// The row of `key`, or -1.
  std::int64_t find(std::uint64_t key) const {
    for (std::size_t s = home(key);; s = (s + 1) & mask_) {
      if (slots_[s].row == kNone) return -1;
      if (slots_[s].key == key) return static_cast<std::int64_t>(slots_[s].row);
    }
  }

 private:
  static constexpr std::uint64_t kNone = ~std::uint64_t{0};  ///< row of an empty slot
  struct Slot {
    std::uint64_t key;
    std::uint64_t row;
  };
  /// The slot a key starts its probe at: the key's bits mixed (its high word, the smaller id,
  /// repeats across a particle's rows).
  std::size_t home(std::uint64_t k) const { return static_cast<std::size_t>(mix64(k)) & mask_; }
  std::vector<Slot> slots_;
  std::size_t mask_ = 0;
};

}  // namespace

namespace {

/// Frees a vector's buffer (clear() keeps it).
template <class T>
void release(std::vector<T>& v) {
  std::vector<T>().swap(v);
}

/// Column `col` of the new rows: row q takes `from(q)`; the old column is freed as the new one
/// replaces it, so a rebuild holds one column twice at a time, never the whole table.
template <class T, class From>
void replace_column(std::vector<T>& col, std::size_t rows, From from) {
  std::vector<T> next(rows);
  for (std::size_t q = 0; q < rows; ++q) next[q] = from(q);
  col.swap(next);
}

}  // namespace

void ContactTable::rebuild(const std::vector<std::array<Index, 2>>& pairs, const std::vector<Id>& ids, std::size_t n_particles,
                           const ContactRebuildRules& rules) {
  // The per-row results (overlaps, forces, torques, incidence) are zeroed by the rebuild and
  // recomputed by the next force pass: freed first, their memory serves the new columns.
  release(overlap_);
  release(force_);
  release(torque_i_);
  release(torque_j_);
  release(inc_row_);
  inc_built_ = false;  // due again: reset_results at the end marks it for the new rows
  const std::size_t w = state_names_.size(), old_rows = size();
  // 1. Where each new row comes from. Candidates first (pair order): the old row of the same key,
  //    whose state it carries, or kFresh; excluded pairs are skipped. Then the old rows their law
  //    keeps alive although they are no longer candidates (old order).
  constexpr std::int64_t kFresh = -1, kSkip = -2;
  std::vector<std::int64_t> from_old(pairs.size());
  std::vector<Index> ni, nj;
  std::vector<std::int64_t> alive_rows;
  {
    RowsByKey old(w > 0 ? old_rows : 0);
    if (w > 0)
      for (std::size_t r = 0; r < old_rows; ++r) old.insert(key(r), r);
    std::vector<char> carried(old_rows, 0);
    std::size_t candidates = 0;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      const Index a = pairs[p][0], b = pairs[p][1];
      const std::uint64_t k = pair_key(ids[a], ids[b]);
      if (rules.excluded && rules.excluded->count(k)) {
        from_old[p] = kSkip;
        continue;
      }
      ++candidates;
      from_old[p] = w > 0 ? old.find(k) : kFresh;
      if (from_old[p] >= 0) carried[from_old[p]] = 1;
    }
    if (rules.alive && w > 0)
      for (std::size_t r = 0; r < old_rows; ++r) {
        if (carried[r] || !rules.alive(state(r))) continue;
        if (rules.excluded && rules.excluded->count(key(r))) continue;
        alive_rows.push_back(static_cast<std::int64_t>(r));
      }
    // 2. Local indices of the new rows (id_i < id_j).
    ni.resize(candidates + alive_rows.size());
    nj.resize(ni.size());
    std::size_t q = 0;
    for (std::size_t p = 0; p < pairs.size(); ++p) {
      if (from_old[p] == kSkip) continue;
      Index a = pairs[p][0], b = pairs[p][1];
      if (ids[a] > ids[b]) std::swap(a, b);
      ni[q] = a;
      nj[q] = b;
      ++q;
    }
    for (const std::int64_t r : alive_rows) {
      ni[q] = i_[r];
      nj[q] = j_[r];
      ++q;
    }
  }
  // 3. The old row of each new row (kFresh: none), then the columns one at a time.
  const std::size_t rows = ni.size(), candidates = rows - alive_rows.size();
  std::vector<std::int64_t> src(rows);
  {
    std::size_t q = 0;
    for (const std::int64_t f : from_old)
      if (f != kSkip) src[q++] = f;
    for (const std::int64_t r : alive_rows) src[q++] = r;
  }
  release(from_old);
  release(alive_rows);
  replace_column(id_i_, rows, [&](std::size_t q) { return q < candidates ? ids[ni[q]] : id_i_[src[q]]; });
  replace_column(id_j_, rows, [&](std::size_t q) { return q < candidates ? ids[nj[q]] : id_j_[src[q]]; });
  i_.swap(ni);
  j_.swap(nj);
  release(ni);
  release(nj);
  {
    std::vector<double> next(rows * w, 0.0);
    for (std::size_t q = 0; q < rows; ++q)
      if (src[q] >= 0) std::copy_n(state_.begin() + src[q] * w, w, next.begin() + q * w);
    state_.swap(next);
  }
  release(src);
  if (!pending_.empty()) {
    for (std::size_t r = 0; r < size(); ++r) {
      auto it = pending_.find(key(r));
      if (it != pending_.end()) copy_named_state(r, it->second.names, it->second.values.data());
    }
    pending_.clear();
  }
  overlap_.assign(size(), 0.0);
  reset_results(n_particles);
}

std::size_t ContactTable::erase_particles(const std::unordered_set<Id>& gone) {
  const std::size_t n = size();
  std::vector<char> keep(n, 1);
  std::size_t dropped = 0;
  for (std::size_t r = 0; r < n; ++r)
    if (gone.count(id_i_[r]) || gone.count(id_j_[r])) {
      keep[r] = 0;
      ++dropped;
    }
  const bool have_overlap = overlap_.size() == n;
  std::size_t q = 0;
  if (have_overlap)
    for (std::size_t r = 0; r < n; ++r)
      if (keep[r]) overlap_[q++] = overlap_[r];
  keep_rows(keep);
  overlap_.resize(size(), 0.0);
  // A pending key is pair_key(a, b) = (min << 32) ^ max: both ids are recovered when they fit
  // 32 bits (always for ids issued by ParticleStore::add below 2^32).
  std::erase_if(pending_, [&](const auto& kv) {
    const Id a = static_cast<Id>(kv.first >> 32), b = static_cast<Id>(kv.first & 0xffffffffu);
    return gone.count(a) || gone.count(b);
  });
  return dropped;
}

void ContactTable::visit(Archive& ar, const std::string& prefix) {
  visit_rows(ar, prefix, "contact");
  if (ar.reading()) overlap_.assign(size(), 0.0);
  // Overlaps of the last force pass: the built-in monitors (contacts, max_overlap_ratio) read
  // them, and a resumed stage checks its `until` conditions before its first force pass.
  if (!ar.reading() || ar.has(prefix + "/overlap")) ar.visit(prefix + "/overlap", overlap_);
  if (overlap_.size() != size())
    throw SetupError("checkpoint contact overlaps have " + std::to_string(overlap_.size()) + " rows, expected " + std::to_string(size()));
  // Forces of the last force pass: the frame a resumed stage writes before its first force pass
  // (a checkpoint at the stage's last step) reports them. The torques are only read by the force
  // pass that recomputes them, so they are not stored.
  if (!ar.reading() || ar.has(prefix + "/force")) ar.visit(prefix + "/force", force_);
  if (force_.size() != size())
    throw SetupError("checkpoint contact forces have " + std::to_string(force_.size()) + " rows, expected " + std::to_string(size()));
  // Pending hand-overs (a bond broke since the last rebuild), in key order.
  std::vector<std::int64_t> keys;
  std::string names;
  std::vector<double> values;
  std::vector<std::int64_t> counts;
  if (!ar.reading()) {
    std::map<std::uint64_t, const HandedState*> sorted;
    for (const auto& [k, st] : pending_) sorted[k] = &st;
    for (const auto& [k, st] : sorted) {
      keys.push_back(static_cast<std::int64_t>(k));
      counts.push_back(static_cast<std::int64_t>(st->names.size()));
      for (const auto& n : st->names) names += n + "\n";
      values.insert(values.end(), st->values.begin(), st->values.end());
    }
  }
  if (!ar.reading() || ar.has(prefix + "/handover/keys")) {
    ar.visit(prefix + "/handover/keys", keys);
    ar.visit(prefix + "/handover/counts", counts);
    ar.visit(prefix + "/handover/names", names);
    ar.visit(prefix + "/handover/values", values);
  }
  if (ar.reading()) {
    pending_.clear();
    if (counts.size() != keys.size()) throw SetupError("checkpoint contact hand-over data is inconsistent");
    std::size_t pos = 0, v = 0;
    for (std::size_t q = 0; q < keys.size(); ++q) {
      HandedState st;
      for (std::int64_t c = 0; c < counts[q]; ++c) {
        const std::size_t e = names.find('\n', pos);
        if (e == std::string::npos || v >= values.size()) throw SetupError("checkpoint contact hand-over data is inconsistent");
        st.names.push_back(names.substr(pos, e - pos));
        st.values.push_back(values[v++]);
        pos = e + 1;
      }
      pending_[static_cast<std::uint64_t>(keys[q])] = std::move(st);
    }
  }
}

}  // namespace sparkdem
