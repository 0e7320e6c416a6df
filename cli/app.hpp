#pragma once
#include <cmath>
#include <filesystem>
// Shared plumbing of the reefgen subcommands.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "reefgen/files.hpp"
#include "reefgen/stats.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen {

const std::map<std::string, std::string>& builtin_presets();           // configs/presets/*.json
const std::map<std::string, std::string>& builtin_floating_presets();  // configs/floating/*.json

struct GlobalOptions {
  bool quiet = false;
};

// Each subcommand registers itself and the function to run once parsed.
struct Command {
  CLI::App* sub;
  std::function<int()> run;
};
Command add_generate_command(CLI::App& app, const GlobalOptions& g);
Command add_presets_command(CLI::App& app, const GlobalOptions& g);
Command add_bench_command(CLI::App& app, const GlobalOptions& g);
Command add_dataset_command(CLI::App& app, const GlobalOptions& g);
Command add_train_command(CLI::App& app, const GlobalOptions& g);
Command add_infer_command(CLI::App& app, const GlobalOptions& g);
Command add_world_command(CLI::App& app, const GlobalOptions& g);
Command add_sketch_command(CLI::App& app, const GlobalOptions& g);
Command add_terrain_command(CLI::App& app, const GlobalOptions& g);
Command add_eval_command(CLI::App& app, const GlobalOptions& g);
Command add_eval_sketches_command(CLI::App& app, const GlobalOptions& g);
Command add_model_command(CLI::App& app, const GlobalOptions& g);
Command add_floating_command(CLI::App& app, const GlobalOptions& g);
Command add_studio_command(CLI::App& app, const GlobalOptions& g);
Command add_realism_command(CLI::App& app, const GlobalOptions& g);
Command add_erode_command(CLI::App& app, const GlobalOptions& g);
// `bench train` and `bench infer` under `bench`; returns their runner.
std::function<int()> add_bench_model_commands(CLI::App* bench);
// `bench realism` (sets *sub to its subcommand); returns its runner.
std::function<int()> add_bench_realism_command(CLI::App* bench, const GlobalOptions& g, CLI::App** sub);
// reefgen bench dataset: pairs/s of dataset build (cmd_bench_dataset.cpp).
std::function<int()> add_bench_dataset_command(CLI::App* bench, const GlobalOptions& g, CLI::App** sub);

// Ctrl-C (SIGINT) and SIGTERM: long-running commands (train, studio) install
// this handler and poll the flag to stop cleanly instead of dying mid-write.
std::atomic<bool>& stop_requested();
void install_stop_handlers();

// Benchmarks: the wall time of one call (timings on a shared machine are
// noisy: report median(), reefgen/stats.hpp, of several).
template <class F>
double seconds_of(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// CLI11 validator: a finite number in [lo, hi]. CLI::Range lets NaN through
// (every comparison with NaN is false), which silently ignored `--subsidence nan`.
inline CLI::Validator finite_in(double lo, double hi) {
  return CLI::Validator(
      [lo, hi](std::string& s) -> std::string {
        double v = 0;
        try {
          size_t used = 0;
          v = std::stod(s, &used);
          if (used != s.size()) return "'" + s + "' is not a number";
        } catch (const std::exception&) {
          return "'" + s + "' is not a number";
        }
        if (!std::isfinite(v) || v < lo || v > hi)
          return "value " + s + " must be a finite number in [" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]";
        return {};
      },
      "FLOAT in [" + CLI::detail::to_string(lo) + ", " + CLI::detail::to_string(hi) + "]");
}

// CLI11 validator for seeds: a whole number in [0, 2^64 - 1]. CLI11 reads an
// unsigned option with strtoull, which turns "-1" into 2^64 - 1 and saturates
// anything larger, so two different seeds silently became the same one.
inline CLI::Validator seed_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        const bool digits = !s.empty() && s.size() <= 20 && s.find_first_not_of("0123456789") == std::string::npos;
        if (!digits || (s.size() == 20 && s > "18446744073709551615"))
          return "seed '" + s + "' must be a whole number in [0, 18446744073709551615]";
        return {};
      },
      "UINT64");
}

}  // namespace reefgen
