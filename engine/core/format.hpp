#pragma once
/// Numbers in messages: the shortest form with `precision` significant digits (%g style).
#include <sstream>
#include <string>

namespace sparkdem {
inline std::string format_number(double x, int precision = 10) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}
}  // namespace sparkdem
