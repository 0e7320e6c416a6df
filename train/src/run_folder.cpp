#include "run_folder.hpp"

#include <fstream>

#include "reefgen/io.hpp"

namespace reefgen::train::detail {

using nlohmann::json;
namespace fs = std::filesystem;

// Keeps the header and the rows of steps <= `step`: a resumed run's logs read
// as if it had never stopped.
void truncate_log(const fs::path& path, int64_t step) {
  if (!fs::exists(path)) return;
  std::ifstream in(path);
  std::string line, out;
  bool header = true;
  while (std::getline(in, line)) {
    const std::string first = line.substr(0, line.find(','));
    const bool is_step = !first.empty() && first.size() < 19 && first.find_first_not_of("0123456789") == std::string::npos;
    if (header || (is_step && std::stoll(first) <= step)) out += line + "\n";  // a torn last row is dropped
    header = false;
  }
  write_text_atomic(path, out);
}

void append_line(const fs::path& path, const std::string& header, const std::string& line) {
  const bool fresh = !fs::exists(path);
  std::ofstream f(path, std::ios::app);
  if (fresh) f << header << "\n";
  f << line << "\n";
  f.flush();
  if (!f) throw Error(path.string() + ": cannot append (disk full?)");
}

// The run folder must not be the dataset or inside it (validation pictures
// and checkpoints would land among the pairs), nor hold the dataset.
void check_run_apart_from_data(const RunOptions& run) {
  std::error_code ec;
  const fs::path d = fs::weakly_canonical(fs::absolute(run.data), ec), o = fs::weakly_canonical(fs::absolute(run.out), ec);
  auto under = [](const fs::path& child, const fs::path& parent) {
    auto c = child.begin();
    for (auto q = parent.begin(); q != parent.end(); ++q, ++c)
      if (c == child.end() || *c != *q) return false;
    return true;
  };
  if (under(o, d) || under(d, o))
    throw Error(run.out.string() + ": the run folder is the dataset " + run.data.string() +
                " or overlaps it; choose an --out outside the dataset");
}

// A resumed run reads the same data as before: another size, height range
// or number of pairs would change the sample order and what the model means.
void check_same_dataset(const RunOptions& run, const DatasetInfo& data, int64_t n) {
  const json before = read_json(run.out / "run.json");
  auto differs = [&](const char* key, const json& now) {
    if (before.contains(key) && before.at(key) != now)
      throw Error(run.data.string() + ": not the dataset this run was started with (" + key + " " +
                  before.at(key).dump() + " then, " + now.dump() + " now; " +
                  before.value("data", std::string("?")) + "); resume with --data " +
                  before.value("data", std::string("?")) + " or start a new run");
  };
  differs("size_px", data.size_px);
  // The manifest lists every pair with its files' checksums: the same
  // manifest is the same data, wherever the folder was moved.
  differs("manifest_fnv64", file_checksum(run.data / "manifest.jsonl"));
  differs("height_range_m", json::array({data.range.lo_m, data.range.hi_m}));
  if (before.contains("pairs")) {
    const json& pb = before.at("pairs");
    if (pb.value("train", int64_t(-1)) != n)
      throw Error(run.data.string() + ": not the dataset this run was started with (" +
                  std::to_string(pb.value("train", int64_t(-1))) + " training pairs then, " + std::to_string(n) +
                  " now); resume with --data " + before.value("data", std::string("?")) + " or start a new run");
  }
}

// Rank 0's guards on the run folder (the only rank that reads and writes
// it), checked before anything is created; `lock` holds the folder's lock.
void open_run_folder(const RunOptions& run, const DatasetInfo& data, int64_t n, std::optional<DirLock>& lock) {
  const fs::path ckpt = run.out / "checkpoint.pt";
  if (run.resume && !fs::exists(ckpt))
    throw Error(run.out.string() + ": no checkpoint.pt to resume from; start a new run without --resume " +
                "(in an empty or new --out folder)");
  if (!run.resume && !run.init_from.empty() && !fs::is_regular_file(run.init_from))
    throw Error(run.init_from.string() +
                ": no such checkpoint to start from (--init takes another run's RUN/checkpoint.pt)");
  ensure_writable_dir(run.out);
  // One process per run folder: two would interleave log.csv and overwrite
  // each other's checkpoints.
  lock.emplace(run.out, "run folder");
  if (run.resume) {  // temp files of a killed run (kill -9 mid-write) are never completed: drop them
    remove_stale_temps(run.out);
    if (fs::is_directory(run.out / "val")) remove_stale_temps(run.out / "val");
  }
  if (run.resume && fs::exists(run.out / "run.json")) check_same_dataset(run, data, n);
  if (!run.resume && fs::exists(ckpt))
    throw Error(run.out.string() + ": already holds a run; pass --resume to continue it or choose another --out");
  // A run that failed before its first checkpoint (full disk, bad data) left
  // run.json and maybe log rows but nothing to resume: a new run starts over.
  if (!run.resume) {
    truncate_log(run.out / "log.csv", 0);
    truncate_log(run.out / "val.csv", 0);
  }
}

// The weights to start from (rank 0): the checkpoint when resuming (with its
// step, log window, logs cut back to it), another run's with --init, else
// the fresh ones. Returns the step.
int64_t restore_start(const RunOptions& run, Pix2Pix& p, const TrainParams& params, LogWindow& window, int world,
                      int64_t Bg) {
  const fs::path ckpt = run.out / "checkpoint.pt";
  if (run.resume && fs::exists(ckpt)) {
    int64_t threads_then = 0, world_then = 1;
    const int64_t step = load_checkpoint(ckpt, p, params, &window, &threads_then, world, &world_then);
    if (threads_then != torch::get_num_threads() && run.on_log)
      run.on_log("warning: the checkpoint was written with " + std::to_string(threads_then) + " LibTorch threads, now " +
                 std::to_string(torch::get_num_threads()) + ": the result will differ slightly from an uninterrupted run");
    if (world_then != world && run.on_log)
      run.on_log("the checkpoint was written by " + std::to_string(world_then) + " rank(s), now " +
                 std::to_string(world) + " with the same global batch of " + std::to_string(Bg) +
                 ": the same run up to rounding (docs/TRAINING.md)");
    truncate_log(run.out / "log.csv", step);
    truncate_log(run.out / "val.csv", step);
    if (run.on_log) run.on_log("resumed " + ckpt.string() + " at step " + std::to_string(step));
    return step;
  }
  if (!run.init_from.empty()) {
    load_checkpoint_weights(run.init_from, p, params);
    if (run.on_log) run.on_log("G and D start from " + run.init_from.string());
  }
  return 0;
}

// run.json: what ran (config, data, schedule, sizes), and where a fine-tuned
// run's weights came from (a resume keeps the record).
json run_record(const json& run_json, const RunOptions& run) {
  json record = run_json;
  if (!run.resume && !run.init_from.empty())
    record["init_from"] = {{"path", fs::absolute(run.init_from).string()}, {"fnv64", file_checksum(run.init_from)}};
  else if (run.resume && fs::exists(run.out / "run.json")) {
    const json before = read_json(run.out / "run.json");
    if (before.contains("init_from")) record["init_from"] = before.at("init_from");
  }
  return record;
}

}  // namespace reefgen::train::detail
