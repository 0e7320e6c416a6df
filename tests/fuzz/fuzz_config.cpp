// libFuzzer target: every JSON a user can hand to reefgen — island specs,
// dataset, training, erosion, floating-island and terrain configs. The only
// acceptable failure is reefgen::Error (or std::invalid_argument from a
// params check), each naming the file and key.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/augment/dataset.hpp"
#include "reefgen/files.hpp"
#include "reefgen/terrain/erosion.hpp"
#include "reefgen/islands/floating.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/islands/terrains.hpp"
#include "reefgen/train/params.hpp"

namespace {
template <class F>
void expect_clean(F&& f) {
  try {
    f();
  } catch (const reefgen::Error&) {
  } catch (const std::invalid_argument&) {
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace reefgen;
  // Through the reader every config goes through (read_json): its depth
  // limit and repeated-key check are part of what is fuzzed. Too deep a
  // nesting or a key twice is a reefgen::Error naming the origin; invalid
  // JSON the library's parse error, which read_json words with its byte.
  nlohmann::json j;
  try {
    j = parse_json_checked(std::string(reinterpret_cast<const char*>(data), size), "fuzz.json");
  } catch (const Error&) {
    return 0;
  } catch (const nlohmann::json::exception&) {
    return 0;
  }
  expect_clean([&] {
    const procgen::IslandSpec s = procgen::spec_from_json(j, "fuzz.json");
    nlohmann::json back;
    procgen::to_json(back, s);
    (void)procgen::spec_from_json(back, "round-trip");  // what we write, we read
  });
  expect_clean([&] { (void)augment::dataset_params_from_json(j, "fuzz.json"); });
  expect_clean([&] { (void)train::train_params_from_json(j, "fuzz.json"); });
  expect_clean([&] { (void)terrain::erosion_params_from_json(j, "fuzz.json"); });
  expect_clean([&] { (void)islands::floating_params_from_json(j, "fuzz.json"); });
  for (const char* kind : {"mapgen4", "wilbur"})  // parsed and run at 16² (the size override keeps it fast)
    expect_clean([&] { (void)islands::configured_terrain(kind, j, "fuzz.json", 16, 1); });
  return 0;
}
