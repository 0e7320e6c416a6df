#pragma once
// Helpers shared by the GoogleTest files.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "reefgen/io.hpp"

namespace reefgen::test {

// A fresh, empty folder under the system temp dir, unique per process.
inline fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("reefgen_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
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

inline int count_files(const fs::path& d) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(d)) (void)e, ++n;
  return n;
}

}  // namespace reefgen::test
