#pragma once
// reefgen's one error type: thrown for anything a user can fix (bad file,
// bad value), with the context that names it; main prints what() on one line
// and exits non-zero. Its own header so that a file can throw without
// pulling in the I/O header.
#include <stdexcept>

namespace reefgen {

struct Error : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace reefgen
