// par::region and the loops built on it (engine/core/parallel.hpp): a loop that is not worth a team
// runs outside the OpenMP runtime (no region of one thread), a worthwhile one on the team, and a
// caller already on a team gets a team of its own for the body (its loops never bind to the caller's).
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <catch2/catch.hpp>
#include <cstdint>
#include <vector>

#include "engine/core/parallel.hpp"

namespace test_parallel {

using namespace sparkdem;

namespace {
/// The thread count of the calling thread's next region, restored on scope exit.
struct Threads {
  int saved = omp_get_max_threads();
  explicit Threads(int n) { omp_set_num_threads(n); }
  ~Threads() { omp_set_num_threads(saved); }
};
std::vector<double> values(std::int64_t n) {
  std::vector<double> v(static_cast<std::size_t>(n));
  for (std::int64_t i = 0; i < n; ++i) v[i] = static_cast<double>((i * 7919) % 100003) - 50000.0;
  return v;
}
}  // namespace

TEST_CASE("par::region: a loop not worth a team runs on the calling thread outside any region; a worthwhile one on the team") {
  for (int threads : {1, 2}) {
    Threads t(threads);
    std::atomic<int> calls{0}, level{-1}, team{0};
    par::region(false, [&] {
      ++calls;
      level = omp_get_level();
      team = omp_get_num_threads();
    });
    CHECK(calls == 1);
    CHECK(level == 0);  // no region was entered
    CHECK(team == 1);
    calls = 0;
    par::region(true, [&] {
      ++calls;
      level = omp_get_level();
    });
    CHECK(calls == threads);
    CHECK(level == (threads > 1 ? 1 : 0));  // one thread: no team of one is built either
  }
}

TEST_CASE("par::loop, par::reduce, par::any_of: every item once and the serial result on one and two threads") {
  const std::int64_t n = 200001;  // above every minimum item count: the team runs them on two threads
  const std::vector<double> v = values(n);
  const double max_serial = *std::max_element(v.begin(), v.end());
  for (int threads : {1, 2}) {
    Threads t(threads);
    std::vector<int> hits(n, 0);
    par::loop(true, n, [&](std::int64_t i) { ++hits[i]; });
    CHECK(std::all_of(hits.begin(), hits.end(), [](int h) { return h == 1; }));
    const double mx = par::reduce(
        n, par::kLight, -1e300, [&](double& m, std::int64_t i) { m = std::max(m, v[i]); },
        [](double& out, double m) { out = std::max(out, m); });
    CHECK(mx == max_serial);
    CHECK(par::any_of(n, par::kLight, [&](std::int64_t i) { return v[i] == max_serial; }));
    CHECK_FALSE(par::any_of(n, par::kLight, [&](std::int64_t i) { return v[i] > max_serial; }));
  }
}

TEST_CASE("par::loop called by each thread of a caller's team covers that thread's whole loop") {
  Threads t(2);
  const std::int64_t n = 100000;
  std::vector<std::vector<int>> hits(2, std::vector<int>(n, 0));
  int team = 0;
#pragma omp parallel num_threads(2)
  {
#pragma omp single
    team = omp_get_num_threads();
    auto& mine = hits[omp_get_thread_num()];
    par::loop(false, n, [&](std::int64_t i) { ++mine[i]; });  // not worth a team
    par::loop(true, n, [&](std::int64_t i) { ++mine[i]; });   // worth one: a nested team (of one here)
  }
  for (int k = 0; k < team; ++k) CHECK(std::all_of(hits[k].begin(), hits[k].end(), [](int h) { return h == 2; }));
}

}  // namespace test_parallel
