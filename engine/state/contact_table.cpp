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

void ContactTable::rebuild(const std::vector<std::array<Index, 2>>& pairs, const std::vector<Id>& ids, std::size_t n_particles,
                           const ContactRebuildRules& rules) {
  const std::size_t w = state_names_.size();
  RowsByKey old(w > 0 ? size() : 0);
  if (w > 0)
    for (std::size_t r = 0; r < size(); ++r) old.insert(key(r), r);
  std::vector<char> carried(size(), 0);
  std::vector<Index> ni, nj;
  std::vector<Id> nidi, nidj;
  std::vector<double> nstate;
  ni.reserve(pairs.size());
  nj.reserve(pairs.size());
  nidi.reserve(pairs.size());
  nidj.reserve(pairs.size());
  nstate.reserve(pairs.size() * w);
  for (const auto& pr : pairs) {
    Index a = pr[0], b = pr[1];
    if (ids[a] > ids[b]) std::swap(a, b);
    const std::uint64_t k = pair_key(ids[a], ids[b]);
    if (rules.excluded && rules.excluded->count(k)) continue;
    ni.push_back(a);
    nj.push_back(b);
    nidi.push_back(ids[a]);
    nidj.push_back(ids[b]);
    nstate.resize(nstate.size() + w, 0.0);
    if (w > 0) {
      const std::int64_t r = old.find(k);
      if (r >= 0) {
        std::copy_n(state_.begin() + r * w, w, nstate.end() - w);
        carried[r] = 1;
      }
    }
  }
  if (rules.alive && w > 0)
    for (std::size_t r = 0; r < size(); ++r) {
      if (carried[r] || !rules.alive(state(r))) continue;
      if (rules.excluded && rules.excluded->count(key(r))) continue;
      ni.push_back(i_[r]);
      nj.push_back(j_[r]);
      nidi.push_back(id_i_[r]);
      nidj.push_back(id_j_[r]);
      nstate.insert(nstate.end(), state_.begin() + r * w, state_.begin() + (r + 1) * w);
    }
  i_.swap(ni);
  j_.swap(nj);
  id_i_.swap(nidi);
  id_j_.swap(nidj);
  state_.swap(nstate);
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
