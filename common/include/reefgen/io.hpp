#pragma once
// All of reefgen's file I/O: files, locks and atomic writes (files.hpp),
// images and height fields (image_io.hpp). Include the one you use.
#include "reefgen/files.hpp"
#include "reefgen/image_io.hpp"
