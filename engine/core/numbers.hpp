#pragma once
/// Constants the sources share: pi and the IEEE special values (quiet NaN, +infinity).
#include <limits>
#include <numbers>

namespace sparkdem {
inline constexpr double kPi = std::numbers::pi;
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace sparkdem
