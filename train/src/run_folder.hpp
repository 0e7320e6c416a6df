// Internal to train/: the run folder — its guards (apart from the data, the
// same dataset on resume, one process at a time), where a run starts from
// (checkpoint, --init or fresh) and its CSV logs.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "reefgen/files.hpp"
#include "reefgen/train/checkpoint.hpp"
#include "reefgen/train/data.hpp"
#include "reefgen/train/pix2pix.hpp"
#include "reefgen/train/trainer.hpp"

namespace reefgen::train::detail {

// Keeps the header and the rows of steps <= `step` (a resumed run's logs read
// as if it had never stopped); a torn last row is dropped.
void truncate_log(const std::filesystem::path& path, int64_t step);
// One CSV row, with the header first in a new file; throws on a full disk.
void append_line(const std::filesystem::path& path, const std::string& header, const std::string& line);
// The run folder is neither the dataset nor inside it, nor holds it.
void check_run_apart_from_data(const RunOptions& run);
// Rank 0's guards on the run folder, checked before anything is created;
// `lock` holds the folder's lock afterwards.
void open_run_folder(const RunOptions& run, const DatasetInfo& data, int64_t n, std::optional<DirLock>& lock);
// The weights to start from (rank 0): the checkpoint when resuming, another
// run's with --init, else the fresh ones. Returns the step.
int64_t restore_start(const RunOptions& run, Pix2Pix& p, const TrainParams& params, LogWindow& window, int world,
                      int64_t Bg);
// run.json: the run's record, with where --init's weights came from.
nlohmann::json run_record(const nlohmann::json& run_json, const RunOptions& run);

}  // namespace reefgen::train::detail
