#pragma once
/// Particle size distributions for powder packing: description, validation, deterministic
/// sampling and comparison of a sample with the requested distribution. Diameters in [m].
///
/// Every distribution is reduced to its NUMBER cumulative distribution N(d) (fraction of
/// particles with diameter <= d); sampling is by inverse CDF, d = N^-1(u), with u drawn from the
/// raw 64-bit engine output (no std:: distributions, whose outputs differ between standard
/// libraries), so a given engine state gives the same diameters everywhere.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "engine/core/error.hpp"

namespace sparkdem::physics {

enum class SizeDistributionKind { table, lognormal, uniform };

/// What the cumulative fractions of a table count.
enum class SizeBasis {
  number,  ///< cumulative fraction of the particle count
  volume,  ///< cumulative fraction of the solid volume (= mass), as in laser-diffraction reports
};

/// One particle size distribution. Build it with make_table / make_lognormal / make_uniform /
/// uniform_about_mean, or fill the fields and call validate().
///
/// table: points (d_k, F_k), k = 0..K-1. The CDF (in `basis`) is 0 below d_0, jumps to F_0 at
///   d_0 (a point mass F_0 AT d_0: the fraction reported "below d_0" is put at d_0, i.e. the
///   distribution starts at d_0), and is linear in d between table points up to F_{K-1} = 1.
///   A single point (d_0, 1) is a monodisperse powder.
/// lognormal: ln d ~ Normal(ln d50, sigma^2), number basis, optionally truncated to
///   [d_min, d_max] (d_min = 0 and d_max = +inf mean no truncation).
/// uniform: d uniform on [d_min, d_max], number basis; d_min == d_max is a monodisperse powder.
struct SizeDistribution {
  SizeDistributionKind kind = SizeDistributionKind::uniform;

  std::vector<double> diameters;            ///< table: d_k [m], > 0, strictly increasing
  std::vector<double> cumulative_fraction;  ///< table: F_k [-] in [0,1], non-decreasing, last = 1 (+-1e-6)
  SizeBasis basis = SizeBasis::number;      ///< table: what F_k counts

  double d50 = 0.0;    ///< lognormal: median (number) diameter [m]
  double sigma = 0.0;  ///< lognormal: standard deviation of ln d [-]

  double d_min = 0.0;                                      ///< lognormal truncation / uniform lower bound [m]
  double d_max = std::numeric_limits<double>::infinity();  ///< lognormal truncation / uniform upper bound [m]
};

/// Tabulated distribution; validated (throws ConfigError).
SizeDistribution make_table(std::vector<double> diameters, std::vector<double> cumulative_fraction, SizeBasis basis);
/// Lognormal number distribution, median d50 [m], sigma of ln d [-], optionally truncated to
/// [d_min, d_max] [m]; validated (throws ConfigError).
SizeDistribution make_lognormal(double d50, double sigma, double d_min = 0.0, double d_max = std::numeric_limits<double>::infinity());
/// Diameters uniform on [d_min, d_max] [m]; validated (throws ConfigError).
SizeDistribution make_uniform(double d_min, double d_max);
/// Radii uniform on [r_mean (1 - spread), r_mean (1 + spread)], i.e. diameters uniform on
/// [2 r_mean (1 - spread), 2 r_mean (1 + spread)]. r_mean [m] > 0, spread [-] in [0, 1)
/// (0 = monodisperse). Throws ConfigError (paths "/r_mean", "/spread").
SizeDistribution uniform_about_mean(double r_mean, double spread);

/// Checks every field used by `dist.kind` and throws ONE ConfigError listing all problems, with
/// paths relative to the distribution ("/diameters/3", "/cumulative_fraction", "/sigma", ...).
void validate(const SizeDistribution& dist);

/// Requested number CDF N(d) [-]: fraction of particles with diameter <= d [m] (right-continuous).
double cdf_number(const SizeDistribution& dist, double d);

/// Number quantile [m]: smallest d with N(d) >= p, p in [0, 1] (p = 0 gives the lower end of the
/// support, p = 1 the upper end, +inf for an untruncated lognormal).
double quantile_number(const SizeDistribution& dist, double p);

/// Number-mean diameter of the requested distribution [m] (closed form for every kind).
double mean_diameter_number(const SizeDistribution& dist);

/// Uniform double in the open interval (0, 1) from one raw engine output:
///   u = (floor(x / 2^11) + 1/2) * 2^-53,   x = rng()
/// (the half offset keeps u away from 0, where the inverse CDF would diverge).
double uniform_open01(std::mt19937_64& rng);

/// One diameter [m] drawn by inverse CDF from exactly one engine output: d = N^-1(u).
/// Validates `dist` (throws ConfigError).
double sample_diameter(const SizeDistribution& dist, std::mt19937_64& rng);

/// Draws diameters until their total sphere volume sum(pi/6 d^3) reaches solid_volume_m3 [m^3].
/// The draw that would cross the target is kept only if it brings the total closer to the target
/// than stopping before it (so |total - target| <= half the last particle's volume; the engine
/// has advanced past that draw either way). solid_volume_m3 = 0 gives an empty vector.
/// Throws ConfigError for a negative or non-finite volume, SetupError if more than max_count
/// particles would be needed.
std::vector<double> sample_until_volume(const SizeDistribution& dist, double solid_volume_m3, std::mt19937_64& rng,
                                        std::size_t max_count = 10'000'000);

/// Requested vs sampled distribution. Quantiles are number quantiles.
struct DistributionReport {
  std::vector<double> quantiles;       ///< probabilities {0.1, 0.5, 0.9} [-]
  std::vector<double> requested_d;     ///< requested d10, d50, d90 (number basis) [m]
  std::vector<double> sampled_d;       ///< sampled d10, d50, d90: smallest sample with F_n >= p [m]
  double ks_distance = 0.0;            ///< sup_d |F_n(d) - N(d)| [-] (Kolmogorov-Smirnov statistic)
  double mean_d_requested = 0.0;       ///< number-mean diameter of the requested distribution [m]
  double mean_d_sampled = 0.0;         ///< arithmetic mean of the samples [m]
  double volume_mean_d_sampled = 0.0;  ///< De Brouckere (volume-weighted) mean D[4,3] = sum d^4 / sum d^3 [m]
  std::size_t n = 0;                   ///< number of samples
};

/// Compares sampled diameters [m] with the requested number distribution. Throws ConfigError for
/// an invalid distribution, an empty sample or a non-positive / non-finite sample.
DistributionReport compare(const SizeDistribution& dist, const std::vector<double>& sampled_diameters);

}  // namespace sparkdem::physics
