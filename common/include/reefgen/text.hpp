// Numbers written into messages, logs and text files, one way each.
#pragma once

#include <cstdio>
#include <string>

namespace reefgen {

// Six significant digits, as printf's "%g" (and an ostream's default):
// 0.0001, 250, 1e+06. Error messages and CSV logs.
inline std::string short_num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%g", v);
  return b;
}

// One number through a printf format ("%.1f", "%.9g"): the engines' scripts
// and sidecars, whose formats their readers fix.
inline std::string format_num(const char* printf_format, double v) {
  char b[64];
  std::snprintf(b, sizeof b, printf_format, v);
  return b;
}

}  // namespace reefgen
