// What two threads can buy on this machine, independent of sparkdem (issue 40 item 1): a loop
// shaped like the velocity-Verlet first half (per particle: read force, torque, mass and inertia,
// update velocity, position, spin and one orientation coefficient: about 200 bytes moved and a
// dozen flops) and a loop of square roots that touches no memory, each timed on 1 and 2 threads.
// The first bounds every pass of a step that streams the particle arrays; the second shows the
// cores themselves are independent.
//   build/benchmarks/stream_scaling [particles ...]    (default 2,000 24,000 200,000 2,000,000)
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <initializer_list>
#include <vector>

namespace {
double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// ns per particle and step of the streaming update on `threads` threads (best of 3).
double stream_ns(long n, int threads) {
  std::vector<double> x(3 * n, 1.0), v(3 * n, 0.1), f(3 * n, 0.01), w(3 * n, 0.0), t(3 * n, 0.01), m(n, 1.0), inertia(n, 1.0),
      q(4 * n, 0.5);
  const double dt = 1e-5;
  const long steps = std::max(20L, 300000000L / n / 10);
  double best = 1e300;
  omp_set_num_threads(threads);
  for (int rep = 0; rep < 3; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    for (long s = 0; s < steps; ++s) {
#pragma omp parallel for schedule(static)
      for (long i = 0; i < n; ++i) {
        const double a = 0.5 * dt / m[i], b = 0.5 * dt / inertia[i];
        for (int c = 0; c < 3; ++c) {
          v[3 * i + c] += a * f[3 * i + c];
          x[3 * i + c] += dt * v[3 * i + c];
          w[3 * i + c] += b * t[3 * i + c];
        }
        q[4 * i] += 1e-9 * w[3 * i];
      }
    }
    best = std::min(best, seconds_since(t0) / static_cast<double>(steps) / static_cast<double>(n) * 1e9);
  }
  return best;
}

/// Seconds of 4e8 square roots summed on `threads` threads (no memory traffic).
double compute_s(int threads) {
  omp_set_num_threads(threads);
  const auto t0 = std::chrono::steady_clock::now();
  double sum = 0.0;
#pragma omp parallel for schedule(static) reduction(+ : sum)
  for (long i = 0; i < 400000000L; ++i) sum += std::sqrt(static_cast<double>(i)) * 1e-9;
  const double s = seconds_since(t0);
  if (!(sum > 0.0)) std::printf("unexpected sum %g\n", sum);
  return s;
}
}  // namespace

int main(int argc, char** argv) {
  std::vector<long> sizes;
  for (int a = 1; a < argc; ++a) sizes.push_back(std::atol(argv[a]));
  if (sizes.empty()) sizes = {2000, 24000, 200000, 2000000};
  std::printf("loop,particles,t1,t2,speedup\n");
  for (long n : sizes) {
    const double t1 = stream_ns(n, 1), t2 = stream_ns(n, 2);
    std::printf("stream [ns/particle-step],%ld,%.3f,%.3f,%.3f\n", n, t1, t2, t1 / t2);
  }
  const double c1 = compute_s(1), c2 = compute_s(2);
  std::printf("sqrt, no memory [s],-,%.3f,%.3f,%.3f\n", c1, c2, c1 / c2);
  return 0;
}
