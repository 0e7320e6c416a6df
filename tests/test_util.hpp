#pragma once
// Helpers shared by the GoogleTest files.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <functional>
#include <type_traits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "reefgen/files.hpp"
#include "reefgen/params_json.hpp"

namespace reefgen::test {

// Sets an environment variable for one scope, then restores it (or unsets it):
// forces a CPU path or backend in a test (tests run one at a time per process).
struct ScopedEnv {
  std::string name;
  std::optional<std::string> old;
  ScopedEnv(std::string n, const char* value) : name(std::move(n)) {
    if (const char* o = std::getenv(name.c_str())) old = o;
    ::setenv(name.c_str(), value, 1);
  }
  ~ScopedEnv() { old ? ::setenv(name.c_str(), old->c_str(), 1) : ::unsetenv(name.c_str()); }
};

// The folders temp_dir made in this process, removed when it exits (also
// after a failed test: GoogleTest returns from main). REEFGEN_KEEP_TEST_DIRS=1
// keeps them to look at.
// Only the process that made them removes them: a forked child (a death
// test, a signal test) that exits must not delete its parent's folders.
struct TempDirs {
  std::vector<fs::path> made;
  pid_t owner = ::getpid();
  ~TempDirs() {
    if (::getpid() != owner) return;
    if (const char* keep = std::getenv("REEFGEN_KEEP_TEST_DIRS"); keep && std::string(keep) == "1") return;
    std::error_code ec;
    for (const auto& d : made) fs::remove_all(d, ec);
  }
};
inline TempDirs& temp_dirs() {
  static TempDirs dirs;
  return dirs;
}

// A fresh, empty folder under the system temp dir, unique per process.
inline fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("reefgen_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  temp_dirs().made.push_back(d);
  return d;
}

// Runs f, expects a reefgen::Error whose message names `needle` (the file or field at fault).
template <class F>
void expect_error_naming(F&& f, const std::string& needle) {
  try {
    f();
    ADD_FAILURE() << "no error; expected one naming " << needle;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

// A W×W test height field in metres: a 400 m bump at (row 20, column 30) on a
// sea floor at −90 m rising 0.5 m per column (land, sea and slopes in one).
inline cv::Mat1f bumpy(int W) {
  cv::Mat1f h(W, W);
  for (int r = 0; r < W; ++r)
    for (int c = 0; c < W; ++c) h(r, c) = float(400 * std::exp(-((r - 20.0) * (r - 20.0) + (c - 30.0) * (c - 30.0)) / 200.0) - 90 + 0.5 * c);
  return h;
}

// A file's bytes ("" when it cannot be read).
inline std::string file_bytes(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), {}};
}

inline int count_files(const fs::path& d) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(d)) (void)e, ++n;
  return n;
}

// Sets every field of a params struct that has a field walk to a value that
// is not its default and lies inside its range (bools flipped, numbers moved
// 37 % of the way to the far end of the range, strings to another of their
// OneOf values, nested structs likewise); free strings and lists are left
// alone (their valid values are not generic).
template <class P>
void set_every_field_off_default(P& p) {
  fields(p, [](const char*, auto& v, auto... range) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (has_fields_v<T>) {
      set_every_field_off_default(v);
    } else if constexpr (std::is_same_v<T, bool>) {
      v = !v;
    } else if constexpr (std::is_same_v<T, std::string> && sizeof...(range) == 1) {
      const OneOf o = (range, ...);
      for (const auto& x : o.values)
        if (x != v) {
          v = x;
          break;
        }
    } else if constexpr (std::is_arithmetic_v<T> && sizeof...(range) == 1) {
      const Range r = (range, ...);
      const double d = double(v), to = (r.hi - d >= d - r.lo) ? r.hi : r.lo;
      double x = d + 0.37 * (to - d);
      if constexpr (std::is_integral_v<T>) x = std::round(x) == d ? d + (to > d ? 1 : -1) : std::round(x);
      v = static_cast<T>(x);
    } else if constexpr (std::is_arithmetic_v<T>) {  // no range: any other value (seeds)
      v = static_cast<T>(v + 1);
    }
  });
}

// The round trip of a params struct through its own to_json and `parse`
// with every field off its default: each field must come back, and each one
// must really have been moved (so a field that serialisation or parsing
// dropped cannot hide behind its default).
// `adjust` may then fix rules between fields (it must not move a field back
// to its default).
template <class P, class Parse>
void expect_params_round_trip(Parse parse, const std::function<void(P&)>& adjust = {}) {
  P p;
  set_every_field_off_default(p);
  if (adjust) adjust(p);
  const nlohmann::json j = params_json(p), d = params_json(P{});
  std::function<void(const nlohmann::json&, const nlohmann::json&, const std::string&)> moved =
      [&](const nlohmann::json& a, const nlohmann::json& b, const std::string& where) {
        for (auto it = a.begin(); it != a.end(); ++it) {
          if (it->is_object()) {
            moved(*it, b.at(it.key()), where + it.key() + ".");
          } else if (it->is_number() || it->is_boolean() || it->is_string()) {
            EXPECT_NE(*it, b.at(it.key())) << where + it.key() << " left at its default";
          }
        }
      };
  moved(j, d, "");
  const P q = parse(j);
  EXPECT_EQ(params_json(q), j);
}

}  // namespace reefgen::test
