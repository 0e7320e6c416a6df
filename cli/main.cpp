// reefgen: coral-reef island terrains from curves or painted sketches.
// Thin main: parse, dispatch, turn every exception into one line + exit 1.
// Built twice (docs/DESIGN.md §7): `reefgen` without LibTorch
// (REEFGEN_TORCH_COMMANDS=0), which hands the network commands to
// `reefgen-torch` (=1, every command) by execv.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cerrno>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include <exception>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "app.hpp"
#include "reefgen/heap.hpp"
#include "reefgen/io.hpp"
#include "reefgen/version.hpp"

namespace reefgen {
namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop = true; }
}  // namespace
std::atomic<bool>& stop_requested() { return g_stop; }
void install_stop_handlers() {
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
}
}  // namespace reefgen

namespace {
// The commands that run a network, handled by reefgen-torch.
const std::vector<std::string> kTorchCommands = {"train", "infer", "world", "eval", "eval-sketches", "model", "studio", "bench"};

#if !REEFGEN_TORCH_COMMANDS
// Replaces this process with reefgen-torch from the same folder, same
// arguments; returns only on failure.
int exec_torch_binary(char** argv, [[maybe_unused]] const std::string& command) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::filesystem::path torch = (ec ? std::filesystem::path(argv[0]) : self).parent_path() / "reefgen-torch";
  ::execv(torch.c_str(), argv);
#if REEFGEN_WITH_TORCH
  std::fprintf(stderr, "reefgen: error: cannot run %s (%s); build it with `cmake --build build --target programs` (scripts/build.sh)\n",
               torch.c_str(), std::strerror(errno));
#else
  std::fprintf(stderr,
               "reefgen: error: %s needs LibTorch, and this reefgen was built without it (-DREEFGEN_WITH_TORCH=OFF); "
               "install libtorch-dev (bash scripts/install-deps.sh) and rebuild with -DREEFGEN_WITH_TORCH=ON\n",
               command.c_str());
#endif
  return 1;
}
#endif

// Edit distance between two (short) words: the nearest command to a typo.
size_t levenshtein(const std::string& w, const std::string& n) {
  std::vector<size_t> prev(n.size() + 1), cur(n.size() + 1);
  for (size_t k = 0; k <= n.size(); ++k) prev[k] = k;
  for (size_t a = 1; a <= w.size(); ++a) {
    cur[0] = a;
    for (size_t k = 1; k <= n.size(); ++k)
      cur[k] = std::min({prev[k] + 1, cur[k - 1] + 1, prev[k - 1] + (w[a - 1] == n[k - 1] ? 0 : 1)});
    std::swap(prev, cur);
  }
  return prev[n.size()];
}

// The first word that is not a global option must be a command: an unknown
// one is named with the nearest of `names` (exit 1, as every error). In the torch-free
// binary a network command is handed to reefgen-torch. -1 = go on parsing.
int check_command_word(int argc, char** argv, const std::vector<std::string>& names) {
  for (int i = 1; i < argc; ++i) {
    const std::string w = argv[i];
    if (w == "-q" || w == "--quiet" || w.rfind("--threads=", 0) == 0) continue;
    if (w == "--threads") {
      ++i;
      continue;
    }
    if (w.empty() || w[0] == '-') return -1;  // other options: CLI11 reports what is wrong
#if !REEFGEN_TORCH_COMMANDS
    if (std::find(kTorchCommands.begin(), kTorchCommands.end(), w) != kTorchCommands.end()) return exec_torch_binary(argv, w);
#endif
    std::string best;
    size_t best_d = 99;
    for (const std::string& n : names) {
      if (n == w) return -1;  // the first word is the command; later words belong to it
      if (const size_t d = levenshtein(w, n); d < best_d) best_d = d, best = n;
    }
    std::fprintf(stderr, "reefgen: error: unknown command '%s'%s (see reefgen --help)\n", w.c_str(),
                 best_d <= 3 ? ("; did you mean '" + best + "'?").c_str() : "");
    return 1;
  }
  return -1;
}

// `reefgen --threads N CMD ...` = `reefgen CMD ... --threads N`: --threads
// belongs to the commands that compute, and may come before them.
std::vector<std::string> threads_after_command(const std::vector<std::string>& args) {
  std::vector<std::string> lead, moved;
  size_t i = 0;
  for (; i < args.size() && !args[i].empty() && args[i][0] == '-'; ++i) {
    if (args[i] == "--threads" && i + 1 < args.size()) {
      moved.push_back(args[i]);
      moved.push_back(args[++i]);
    } else if (args[i].rfind("--threads=", 0) == 0) {
      moved.push_back(args[i]);
    } else {
      lead.push_back(args[i]);
    }
  }
  if (moved.empty() || i == args.size()) return args;
  std::vector<std::string> out = lead;
  out.insert(out.end(), args.begin() + long(i), args.end());
  out.insert(out.end(), moved.begin(), moved.end());
  return out;
}

// Every command this binary runs (the network commands in reefgen-torch only).
std::vector<reefgen::Command> add_commands(CLI::App& app, reefgen::GlobalOptions& g) {
  std::vector<reefgen::Command> commands;
  for (auto add : {reefgen::add_generate_command, reefgen::add_presets_command, reefgen::add_dataset_command,
                   reefgen::add_sketch_command, reefgen::add_terrain_command, reefgen::add_floating_command,
                   reefgen::add_realism_command, reefgen::add_erode_command})
    commands.push_back(add(app, g));
#if REEFGEN_TORCH_COMMANDS
  for (auto add : {reefgen::add_train_command, reefgen::add_infer_command, reefgen::add_world_command, reefgen::add_eval_command,
                   reefgen::add_eval_sketches_command, reefgen::add_model_command, reefgen::add_studio_command,
                   reefgen::add_bench_command})
    commands.push_back(add(app, g));
#endif
  return commands;
}

// No command word (--help, --version, nothing): the full list of commands
// lives in reefgen-torch, which this process becomes; -1 otherwise.
int hand_help_to_torch([[maybe_unused]] int argc, [[maybe_unused]] char** argv) {
#if !REEFGEN_TORCH_COMMANDS
  bool has_command = false;
  for (int i = 1; i < argc; ++i) {
    const std::string w = argv[i];
    if (w == "--threads") ++i;
    else if (!w.empty() && w[0] != '-') has_command = true;
  }
  // Without LibTorch there is no other half: this binary prints its own list.
  if (!has_command && REEFGEN_WITH_TORCH) return exec_torch_binary(argv, "--help");
#endif
  return -1;
}

// Parses `args`; a parse error is one line, as every other error. Returns the
// exit code when the process is done (an error, --help, --version), else -1.
int parse_command_line(CLI::App& app, const char* argv0, const std::vector<std::string>& args) {
  try {
    std::vector<const char*> av{argv0};
    for (const auto& a : args) av.push_back(a.c_str());
    app.parse(int(av.size()), av.data());
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // The problem, then where to look.
    std::string what = e.what();
    for (auto& ch : what)
      if (ch == '\n') ch = ' ';
    std::fprintf(stderr, "reefgen: error: %s (see reefgen --help)\n", what.c_str());
    // Every error exits 1 (README), CLI11's own codes (105 for a value out
    // of its check, 106, 109) included.
    return 1;
  }
  return -1;
}

// Runs the parsed command; an error is one line on stderr.
int run_command(const std::vector<reefgen::Command>& commands) {
  try {
    for (const auto& c : commands)
      if (c.sub->parsed()) return c.run();
  } catch (const std::exception& e) {
    // Library texts may span lines (LibTorch appends a stack trace): keep the first.
    std::string what = e.what();
    what = what.substr(0, what.find('\n'));
    std::fprintf(stderr, "reefgen: error: %s\n", what.c_str());
    reefgen::remove_empty_made_dirs();
    return 1;
  }
  return 0;
}
}  // namespace

int main(int argc, char** argv) {
  // OpenCV's [WARN] lines are not for users: every problem reaches them as
  // one line from reefgen, naming the file (read_image and friends).
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_ERROR);
  reefgen::remove_temps_on_fatal_signals();
  reefgen::keep_freed_images();
  CLI::App app{"reefgen " + std::string(reefgen::kVersion) +
               " - procedural and learning-based coral reef island terrains\n\n"
               "Examples:\n"
               "  reefgen generate --preset atoll -o out/atoll --preview\n"
               "  reefgen generate --spec my_island.json -o out/mine --size 512\n"
               "  reefgen generate --random 100 --seed 7 --out out/random --threads 2\n"
               "  reefgen presets\n"
               "  reefgen dataset build --config configs/dataset/paper.json --out data/paper --seed 1\n"
               "  reefgen train --data data/paper --out runs/paper\n"
               "  reefgen sketch random --seed 3 -o sketch.png\n"
               "  reefgen terrain mapgen4 --seed 2 -o out/m4 --preview\n"
               "  reefgen floating --painting docs/examples/floating-painting.png -o out/floating.glb --preview out/floating.png\n"
               "  reefgen infer sketch.png -m runs/paper/generator.pt -o out/island --preview --r16\n"
               "  reefgen eval -m runs/paper/generator.pt --data data/paper --split test\n"
               "  reefgen studio                      # paint in the browser, see it in 3D\n"
               "  reefgen realism out/atoll.height.exr   # pits, terraces, valleys\n"
               "  reefgen erode dem.tif -o out/dem --layers --geotiff   # your heightmap, eroded\n"
               "  reefgen bench generate\n"};
  app.set_version_flag("--version", std::string("reefgen ") + reefgen::kVersion);
  app.require_subcommand(1);
  // Global flags anywhere on the line (clig.dev): options a subcommand does
  // not know fall through to reefgen's own (-q after the command works).
  app.fallthrough();
  reefgen::GlobalOptions g;
  app.add_flag("-q,--quiet", g.quiet, "No progress or log lines on stderr (anywhere on the line)");
  // Commands that compute in parallel have their own --threads (it reaches
  // them from anywhere on the line, see below); the others accept it too, so
  // one wrapper script can pass it to every command, and cap OpenCV's pool.
  int threads = 0;
  app.add_option("--threads", threads, "Worker threads (commands that compute in parallel; accepted by all)")
      ->check(CLI::Range(1, 256));
  const std::vector<reefgen::Command> commands = add_commands(app, g);
  // An unknown command word is named, with the nearest known one.
  std::vector<std::string> names = kTorchCommands;
  for (const auto& c : commands) names.push_back(c.sub->get_name());
  if (const int rc = check_command_word(argc, argv, names); rc >= 0) return rc;
  if (const int rc = hand_help_to_torch(argc, argv); rc >= 0) return rc;
  const std::vector<std::string> args = threads_after_command(std::vector<std::string>(argv + 1, argv + argc));
  if (const int rc = parse_command_line(app, argv[0], args); rc >= 0) return rc;
  if (threads > 0) cv::setNumThreads(threads);
  // REEFGEN_PARSE_ONLY=1: check the command line and stop (tests/doc_commands.sh
  // parses every command the docs show).
  if (const char* p = std::getenv("REEFGEN_PARSE_ONLY"); p && std::string(p) == "1") return 0;
  return run_command(commands);
}
