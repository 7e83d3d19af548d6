/// Sweep items spread over MPI ranks (see sweep_items.hpp and io/mpi/ranks.hpp).
///
/// Rank 0 owns the plan, the table and the checkpoints. Its main thread runs items like any
/// other rank; a second thread (the dispatcher) hands items to the other ranks as they come free
/// and collects their rows. The plan is the one-rank plan: item j's row lands at place j whatever
/// the order the items finish in, a calibration's search items wait for every earlier row (each
/// depends on all of them), its scan and validation items do not. The other ranks wait in
/// serve_sweep_items for an item or the stop signal, sleeping between probes.
#include <algorithm>
#include <condition_variable>
#include <exception>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "engine/core/error.hpp"
#include "engine/core/interrupt.hpp"
#include "engine/graph/hypre_amg.hpp"
#include "io/mpi/ranks.hpp"
#include "io/scenario/sweep_items.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace sweep_detail {

namespace {

/// The plan of one sweep, shared by rank 0's two threads.
class Scheduler {
 public:
  Scheduler(const SweepContext& ctx, std::function<void(const std::map<std::size_t, json>&)> progress)
      : ctx_(ctx), progress_(std::move(progress)), rows_(ctx.done) {}

  /// The next item to run; `wait`: block until one can be planned or the sweep is over (then
  /// nothing); otherwise nothing when none can be planned now.
  std::optional<ItemJob> take(bool wait) {
    std::unique_lock lock(m_);
    for (;;) {
      if (error_) return std::nullopt;
      if (auto job = plan_locked()) return job;
      if (!wait || over_locked()) return std::nullopt;
      cv_.wait(lock);
    }
  }
  void complete(std::size_t j, ItemResult r) {
    std::lock_guard lock(m_);
    running_.erase(j);
    rows_[j] = r.row;
    ran_[j] = std::move(r);
    try {
      progress_(rows_);
    } catch (...) {
      if (!error_) error_ = std::current_exception();
    }
    cv_.notify_all();
  }
  void fail(std::size_t j, std::exception_ptr e) {
    std::lock_guard lock(m_);
    running_.erase(j);
    if (!error_) error_ = e;
    cv_.notify_all();
  }
  /// No item left to hand out and none running.
  bool over() {
    std::lock_guard lock(m_);
    return over_locked();
  }
  std::exception_ptr error() {
    std::lock_guard lock(m_);
    return error_;
  }
  std::map<std::size_t, ItemResult> results() {
    std::lock_guard lock(m_);
    return ran_;
  }

 private:
  bool over_locked() const { return running_.empty() && (exhausted_ || error_); }
  /// The next item that can be planned now: any item of a plain sweep, a calibration's scan item
  /// or its next validation item; a search item (or the first item after the scan) only when
  /// every earlier row is in.
  std::optional<ItemJob> plan_locked() {
    const SweepDef& sw = *ctx_.sw;
    while (!exhausted_) {
      const std::size_t j = next_;
      if (rows_.count(j)) {  // finished before a restart
        ++next_;
        continue;
      }
      // Validation items follow one another: item j validates snapshot j - first_validation_.
      const bool validating = first_validation_.has_value();
      const bool independent = !sw.calibrate || j < sw.calibrate->scan.size() || validating;
      if (!independent && !running_.empty()) return std::nullopt;
      std::optional<Item> item;
      if (validating) {
        if (j - *first_validation_ < ctx_.n) item = Item{j - *first_validation_, calibrated_, "validate"};
      } else {
        try {
          item = plan_item(ctx_, j, rows_);
        } catch (...) {
          error_ = std::current_exception();
          return std::nullopt;
        }
      }
      if (!item) {
        exhausted_ = true;
        return std::nullopt;
      }
      if (item->phase == "validate" && !validating) {
        first_validation_ = j - item->index;
        calibrated_ = item->value;
      }
      ++next_;
      running_.insert(j);
      return job_of(ctx_, j, *item);
    }
    return std::nullopt;
  }

  const SweepContext& ctx_;
  std::function<void(const std::map<std::size_t, json>&)> progress_;
  std::mutex m_;
  std::condition_variable cv_;
  std::map<std::size_t, json> rows_;
  std::map<std::size_t, ItemResult> ran_;
  std::set<std::size_t> running_;
  std::size_t next_ = 0;
  bool exhausted_ = false;
  std::optional<std::size_t> first_validation_;  ///< item number of the (virtual) validation of snapshot 0
  double calibrated_ = 0.0;
  std::exception_ptr error_;
};

/// Rank 0's second thread: keeps every other rank busy until the plan is over.
void dispatch(Scheduler& sched) {
  int busy = 0;  // ranks running an item
  std::vector<int> idle;
  for (int r = ranks::size() - 1; r >= 1; --r) idle.push_back(r);
  for (;;) {
    while (!idle.empty()) {
      auto job = sched.take(false);
      if (!job) break;
      const int r = idle.back();
      idle.pop_back();
      ++busy;
      ranks::send(r, ranks::kItem, job->to_json().dump());
    }
    if (busy == 0 && (sched.over() || sched.error())) return;
    if (auto m = ranks::poll(ranks::kResult)) {
      const json x = json::parse(m->text);
      const std::size_t j = x.at("j").get<std::size_t>();
      --busy;
      idle.push_back(m->source);
      if (x.contains("error")) {
        const std::string what = "rank " + std::to_string(m->source) + ", sweep item " + std::to_string(j) + ": " +
                                 x["error"].get<std::string>();
        const std::string kind = x.value("kind", "");
        std::exception_ptr e = kind == "interrupted" ? std::make_exception_ptr(Interrupted(what))
                               : kind == "setup"     ? std::make_exception_ptr(SetupError(what))
                                                     : std::make_exception_ptr(std::runtime_error(what));
        sched.fail(j, e);
      } else {
        ItemResult r;
        r.row = x.at("row");
        r.steps = x.at("steps").get<Step>();
        r.particle_steps = x.at("particle_steps").get<double>();
        sched.complete(j, std::move(r));
      }
      continue;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
}

/// Item checkpoints of a run on several ranks go to the item's own directory (a restart reruns
/// an unfinished item from its start, so they only serve the item's own crash outputs).
RunOptions spread_item_options(const ItemJob& job) {
  RunOptions o;
  o.checkpoint_file = fs::path(job.directory) / "checkpoint.h5";
  return o;
}

}  // namespace

std::map<std::size_t, ItemResult> run_items_over_ranks(Scenario& sc, const SweepContext& ctx,
                                                       const std::function<void(const std::map<std::size_t, json>&)>& progress) {
  // The other ranks run items now: rank 0's network solves stay on rank 0 until the sweep ends.
  struct SolveAlone {
    int before = amg_spread_ranks();
    SolveAlone() { set_amg_spread_ranks(1); }
    ~SolveAlone() { set_amg_spread_ranks(before); }
  } alone;
  Scheduler sched(ctx, progress);
  std::thread dispatcher([&sched] {
    try {
      dispatch(sched);
    } catch (...) { sched.fail(static_cast<std::size_t>(-1), std::current_exception()); }
  });
  while (auto job = sched.take(true)) {
    try {
      ItemResult r = run_item(sc, *job, ctx.input, spread_item_options(*job));
      sched.complete(job->j, std::move(r));
    } catch (...) { sched.fail(job->j, std::current_exception()); }
  }
  dispatcher.join();
  if (auto e = sched.error()) std::rethrow_exception(e);
  return sched.results();
}

}  // namespace sweep_detail

int serve_sweep_items(Scenario& sc) {
  using namespace sweep_detail;
  std::string input_file;  // the current sweep's input state, read once per sweep
  State input;
  for (;;) {
    const ranks::Message m = ranks::wait(-1);
    if (m.tag == ranks::kStop) return json::parse(m.text).value("exit_code", 0);
    if (m.tag == kAmgCommandTag) {  // rank 0 spreads a network solve (engine/graph/hypre_amg.hpp)
      serve_amg_command(m.text);
      continue;
    }
    if (m.tag != ranks::kItem) continue;
    json reply;
    std::size_t j = 0;
    try {
      const ItemJob job = ItemJob::from_json(json::parse(m.text));
      j = job.j;
      reply["j"] = j;
      if (job.input_state != input_file) {
        input_file.clear();
        input = State{};
        read_checkpoint(job.input_state, input);
        input.materials = sc.materials;
        input_file = job.input_state;
      }
      ItemResult r = run_item(sc, job, input, spread_item_options(job));
      reply["row"] = r.row;
      reply["steps"] = r.steps;
      reply["particle_steps"] = r.particle_steps;
    } catch (const Interrupted& e) { reply = {{"j", j}, {"error", e.what()}, {"kind", "interrupted"}}; } catch (const SetupError& e) {
      reply = {{"j", j}, {"error", e.what()}, {"kind", "setup"}};
    } catch (const std::exception& e) { reply = {{"j", j}, {"error", e.what()}, {"kind", "internal"}}; }
    ranks::send(0, ranks::kResult, reply.dump());
  }
}

void stop_sweep_servers(int exit_code) {
  if (ranks::rank() != 0) return;
  const std::string msg = json{{"exit_code", exit_code}}.dump();
  for (int r = 1; r < ranks::size(); ++r) ranks::send(r, ranks::kStop, msg);
}

}  // namespace sparkdem::io
