// Issue 39 item 4: where does the segregated phi_c of seed 002 (lambda = 35 R: 13.7 % here, ~4 % in
// the paper) get lost? The generator's steps (physics/packing/cpc_fillers.hpp) run one by one on
// the same configurations, and the spanning cluster is checked after each:
//   A  after the first contact algorithm (the homogeneous configuration),
//   B  after the aggregation (SM S2, Fig. S3), before the second contact algorithm,
//   C  after the second contact algorithm (the generator's output).
// A configuration spans when one cluster of contacts (gap <= 0.1 % of D, as contact_percolation's
// touch_tolerance 0.002 R) holds a sphere crossing x = 0 and one crossing x = L (touching_wall,
// tolerance 0). Also per step: the largest cluster's share, contacts per sphere, and at B the
// largest relative overlap and the number of overlapping pairs (what C has to undo).
//
//   bench_aggregation L lambda phi1,phi2,... seeds   -> CSV on stdout
// Positions: uniform in [0, L]^3 from mt19937_64(seed) via uniform_open01, as the generator.
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "physics/packing/cpc_fillers.hpp"
#include "physics/packing/size_distribution.hpp"

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

struct StepFigures {
  bool spans = false;
  double largest_share = 0.0;   ///< largest cluster / N
  double contacts_per_sphere = 0.0;
  std::size_t overlapping_pairs = 0;  ///< pairs with relative overlap > 1e-3 (what a contact run must undo)
  double max_overlap = 0.0;
};

StepFigures figures(const std::vector<Vec3>& x, const std::vector<double>& r, double L) {
  StepFigures f;
  const auto pairs = cpc::contact_pairs(x, r, 1e-3);
  const std::vector<Index> label = cpc::cluster_labels(x.size(), pairs);
  std::vector<std::size_t> size(x.size(), 0);
  std::vector<char> lo(x.size(), 0), hi(x.size(), 0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    ++size[label[i]];
    if (x[i].x() - r[i] <= 0.0) lo[label[i]] = 1;
    if (x[i].x() + r[i] >= L) hi[label[i]] = 1;
  }
  std::size_t big = 0;
  for (std::size_t l = 0; l < x.size(); ++l) {
    big = std::max(big, size[l]);
    f.spans = f.spans || (lo[l] && hi[l]);
  }
  f.largest_share = static_cast<double>(big) / static_cast<double>(x.size());
  f.contacts_per_sphere = 2.0 * static_cast<double>(pairs.size()) / static_cast<double>(x.size());
  for (const auto& p : pairs) {
    const double g = 1.0 - (x[p[0]] - x[p[1]]).norm() / (r[p[0]] + r[p[1]]);
    if (g > 1e-3) ++f.overlapping_pairs;
  }
  f.max_overlap = cpc::max_relative_overlap(x, r);
  return f;
}

std::vector<double> parse_list(const char* s) {
  std::vector<double> v;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) v.push_back(std::atof(item.c_str()));
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: bench_aggregation L lambda phi1,phi2,... seeds\n");
    return 2;
  }
  const double L = std::atof(argv[1]), lambda = std::atof(argv[2]), R = 1.0;
  const std::vector<double> phis = parse_list(argv[3]);
  const int seeds = std::atoi(argv[4]);
  std::printf(
      "L,lambda,phi,seed,N,moved,spans_A,spans_B,spans_C,largest_A,largest_B,largest_C,z_A,z_B,z_C,overlapping_pairs_B,max_overlap_B,"
      "second_contact_iterations\n");
  for (double phi : phis)
    for (int seed = 1; seed <= seeds; ++seed) {
      const auto n = static_cast<std::size_t>(std::round(phi * L * L * L / (4.0 / 3.0 * M_PI * R * R * R)));
      std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
      std::vector<Vec3> x(n);
      const std::vector<double> r(n, R);
      for (auto& p : x)
        for (int d = 0; d < 3; ++d) p[d] = L * uniform_open01(rng);
      cpc::remove_overlaps(x, r, 0.4, 1e-3, 1000000);
      const StepFigures a = figures(x, r, L);
      const cpc::Aggregation agg = cpc::aggregate(x, r, lambda, 1e-3, rng);
      const StepFigures b = figures(x, r, L);
      const cpc::OverlapRemoval second = cpc::remove_overlaps(x, r, 0.4, 1e-3, 1000000);
      const StepFigures c = figures(x, r, L);
      std::printf("%g,%g,%g,%d,%zu,%zu,%d,%d,%d,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f,%zu,%.4g,%lld\n", L, lambda, phi, seed, n, agg.moved, a.spans,
                  b.spans, c.spans, a.largest_share, b.largest_share, c.largest_share, a.contacts_per_sphere, b.contacts_per_sphere,
                  c.contacts_per_sphere, b.overlapping_pairs, b.max_overlap, static_cast<long long>(second.iterations));
      std::fflush(stdout);
    }
  return 0;
}
