#pragma once
/// The measured figures of the extreme-case catalogue (docs/extreme_cases.md). Every case reports
/// its figures with EXTREME_FIGURE(case, name, value, unit): printed as a Catch2 warning (so
/// `sparkdem_tests "[extreme]"` shows them) and, when the environment variable
/// SPARKDEM_EXTREME_CSV names a file, appended to it as `case,figure,value,unit`.
#include <cstdio>
#include <cstdlib>
#include <string>

namespace sparkdem::test {

inline void append_extreme_figure(const std::string& case_name, const std::string& figure, double value, const std::string& unit) {
  const char* path = std::getenv("SPARKDEM_EXTREME_CSV");
  if (!path || !*path) return;
  if (std::FILE* f = std::fopen(path, "a")) {
    std::fprintf(f, "%s,%s,%.6g,%s\n", case_name.c_str(), figure.c_str(), value, unit.c_str());
    std::fclose(f);
  }
}

}  // namespace sparkdem::test

#define EXTREME_FIGURE(case_name, figure, value, unit)                                             \
  do {                                                                                             \
    const double extreme_v_ = (value);                                                             \
    WARN("[extreme] " << (case_name) << ": " << (figure) << " = " << extreme_v_ << " " << (unit)); \
    ::sparkdem::test::append_extreme_figure(case_name, figure, extreme_v_, unit);                  \
  } while (0)
