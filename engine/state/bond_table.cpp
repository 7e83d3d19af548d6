#include "engine/state/bond_table.hpp"

#include <algorithm>

#include "engine/core/error.hpp"

namespace sparkdem {

BondReference make_bond_reference(const Vec3& xi, const Vec3& xj, const Quat& qi, const Quat& qj) {
  BondReference ref;
  const Vec3 d = xj - xi;
  ref.length0 = d.norm();
  const Vec3 axis = ref.length0 > 0.0 ? Vec3(d / ref.length0) : Vec3(Vec3::UnitX());
  // A world vector normal to the axis: the coordinate axis least aligned with it, orthogonalised.
  Vec3 e = Vec3::Zero();
  int k = 0;
  axis.cwiseAbs().minCoeff(&k);
  e[k] = 1.0;
  const Vec3 perp = (e - e.dot(axis) * axis).normalized();
  const Quat qi_inv = qi.conjugate(), qj_inv = qj.conjugate();
  ref.dir_i = qi_inv * axis;
  ref.dir_j = qj_inv * (-axis);
  ref.perp_i = qi_inv * perp;
  ref.perp_j = qj_inv * perp;
  return ref;
}

std::size_t BondTable::add(Index a, Index b, const std::vector<Id>& ids, const std::vector<Vec3>& x, const std::vector<Quat>& q,
                           const HandedState& handed) {
  if (a == b) throw SetupError("a bond needs two different particles (id " + std::to_string(ids[a]) + ")");
  if (ids[a] > ids[b]) std::swap(a, b);
  i_.push_back(a);
  j_.push_back(b);
  id_i_.push_back(ids[a]);
  id_j_.push_back(ids[b]);
  state_.resize(state_.size() + state_names_.size(), 0.0);
  ref_.push_back(make_bond_reference(x[a], x[b], q[a], q[b]));
  broken_.push_back(0);
  broken_step_.push_back(-1);
  record_.push_back({});
  const std::size_t r = size() - 1;
  if (!handed.names.empty()) copy_named_state(r, handed.names, handed.values.data());
  ++version_;
  dirty_ = true;
  return r;
}

void BondTable::mark_broken(std::size_t r, Step step, const BondBreakRecord& record) {
  if (broken_[r]) return;
  broken_[r] = 1;
  broken_step_[r] = step;
  record_[r] = record;
  if (r < force_.size()) force_[r].setZero();
  if (r < torque_i_.size()) torque_i_[r].setZero();
  if (r < torque_j_.size()) torque_j_[r].setZero();
  ++version_;
}

std::size_t BondTable::intact_count() const {
  return static_cast<std::size_t>(std::count(broken_.begin(), broken_.end(), std::uint8_t{0}));
}

const std::unordered_set<std::uint64_t>& BondTable::intact_keys() const {
  if (keys_version_ != version_) {
    keys_.clear();
    for (std::size_t r = 0; r < size(); ++r)
      if (!broken_[r]) keys_.insert(key(r));
    keys_version_ = version_;
  }
  return keys_;
}

std::size_t BondTable::erase_particles(const std::unordered_set<Id>& gone) {
  const std::size_t n = size();
  std::vector<char> keep(n, 1);
  std::size_t q = 0;
  for (std::size_t r = 0; r < n; ++r) {
    keep[r] = !(gone.count(id_i_[r]) || gone.count(id_j_[r]));
    if (!keep[r]) continue;
    ref_[q] = ref_[r];
    broken_[q] = broken_[r];
    broken_step_[q] = broken_step_[r];
    record_[q] = record_[r];
    ++q;
  }
  ref_.resize(q);
  broken_.resize(q);
  broken_step_.resize(q);
  record_.resize(q);
  keep_rows(keep);
  if (q != n) {
    ++version_;
    dirty_ = true;
  }
  return n - q;
}

HandedState BondTable::handed_state(std::size_t r) const {
  HandedState h;
  h.names = state_names_;
  h.values.assign(state(r), state(r) + state_width());
  return h;
}

void BondTable::visit(Archive& ar, const std::string& prefix) {
  visit_rows(ar, prefix, "bond");
  std::vector<double> ref;
  if (!ar.reading())
    for (const auto& b : ref_) {
      ref.push_back(b.length0);
      for (const Vec3* v : {&b.dir_i, &b.dir_j, &b.perp_i, &b.perp_j}) ref.insert(ref.end(), v->data(), v->data() + 3);
    }
  ar.visit(prefix + "/reference", ref, 13);
  std::vector<std::int64_t> br(broken_.begin(), broken_.end());
  ar.visit(prefix + "/broken", br);
  ar.visit(prefix + "/broken_step", broken_step_);
  std::vector<double> rec;
  std::vector<std::int64_t> modes;
  if (!ar.reading())
    for (const auto& b : record_) {
      rec.insert(rec.end(), {b.time, b.position[0], b.position[1], b.position[2]});
      modes.push_back(b.mode);
    }
  ar.visit(prefix + "/break_record", rec, 4);
  ar.visit(prefix + "/break_mode", modes);
  std::int64_t rule = contact_rule == ContactRule::Add ? 1 : 0;
  ar.visit(prefix + "/contact_rule_add", rule);
  if (ar.reading()) {
    if (ref.size() != 13 * size() || br.size() != size() || broken_step_.size() != size())
      throw SetupError("checkpoint bond table is inconsistent: " + std::to_string(size()) + " rows");
    ref_.assign(size(), {});
    for (std::size_t r = 0; r < size(); ++r) {
      const double* p = ref.data() + 13 * r;
      ref_[r].length0 = p[0];
      ref_[r].dir_i = Vec3(p[1], p[2], p[3]);
      ref_[r].dir_j = Vec3(p[4], p[5], p[6]);
      ref_[r].perp_i = Vec3(p[7], p[8], p[9]);
      ref_[r].perp_j = Vec3(p[10], p[11], p[12]);
    }
    if (rec.size() != 4 * size() || modes.size() != size())
      throw SetupError("checkpoint bond break records are inconsistent: " + std::to_string(size()) + " rows");
    record_.assign(size(), {});
    for (std::size_t r = 0; r < size(); ++r) record_[r] = {rec[4 * r], Vec3(rec[4 * r + 1], rec[4 * r + 2], rec[4 * r + 3]), modes[r]};
    broken_.assign(br.begin(), br.end());
    contact_rule = rule ? ContactRule::Add : ContactRule::Exclude;
    ++version_;
    dirty_ = true;
  }
}

}  // namespace sparkdem
