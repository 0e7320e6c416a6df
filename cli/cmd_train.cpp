// reefgen train: pix2pix on a dataset folder (paper §6, docs/TRAINING.md).
// Thin: flags -> TrainParams, signals -> a stop flag, progress -> stderr.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <optional>

#include <unistd.h>

#include "app.hpp"
#include "reefgen/files.hpp"
#include "reefgen/train/trainer.hpp"

namespace reefgen {

namespace {

// `train --nproc N`: this command line again, without --nproc, as N ranks.
int launch_ranks(int nproc, int port, const GlobalOptions& g) {
  std::ifstream f("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> argv;
  for (std::string arg; std::getline(f, arg, '\0');) argv.push_back(arg);
  std::vector<std::string> args;
  for (size_t i = 1; i < argv.size(); ++i) {
    if (argv[i] == "--nproc") {
      ++i;
      continue;
    }
    if (argv[i].rfind("--nproc=", 0) == 0) continue;
    args.push_back(argv[i]);
  }
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
  if (n <= 0) throw Error("/proc/self/exe: cannot find this program to start the ranks");
  exe[n] = '\0';
  install_stop_handlers();
  train::LocalLaunch l;
  l.exe = exe;
  l.args = args;
  l.nproc = nproc;
  l.port = port;
  l.stop = &stop_requested();
  l.on_log = [&](const std::string& s) {
    if (!g.quiet) std::fprintf(stderr, "train: %s\n", s.c_str());
  };
  return train::launch_local_ranks(l);
}


struct TrainArgs {
  std::string config, data, out;
  bool resume = false;
  std::string init;
  int64_t max_steps = -1;
  std::optional<uint64_t> seed;
  std::optional<int> threads, ngf, ndf, depth;
  std::optional<double> epochs, epochs_decay;
  std::optional<std::string> engine, precision;
  std::optional<int> batch_size, log_every;
  int nproc = 1;
  double bucket_mb = 4;
  bool no_verify = false;
  train::DistFlags dist;
};

void add_train_options(CLI::App* sub, TrainArgs& a) {
  sub->add_option("--config", a.config, "Training config JSON (configs/train/*.json); default: built-in paper settings");
  sub->add_option("--data", a.data, "Dataset folder made by `reefgen dataset build`")->required();
  sub->add_option("-o,--out,--output", a.out, "Run folder (created)")->required();
  sub->add_flag("--resume", a.resume, "Continue the run in --out from its checkpoint (its run.json config unless --config)");
  sub->add_option("--init", a.init,
                  "Start G and D from another run's checkpoint.pt (same networks; fresh optimizers at step 0), "
                  "e.g. to fine-tune with another lambda_l1 or schedule; or G alone from an exported generator "
                  "(RUN/generator.pt, models/reef-256.pt), D fresh: fine-tuning the shipped model on new targets")
      ->excludes("--resume");
  sub->add_option("--max-steps", a.max_steps, "Stop after this many steps in all (checkpoint written); the lr schedule still spans the whole run")
      ->check(CLI::Range(int64_t(1), std::numeric_limits<int64_t>::max()));
  sub->add_option("--seed", a.seed, "Overrides the config's seed")->check(seed_value());
  sub->add_option("--threads", a.threads, "LibTorch threads (default: all cores)")->check(CLI::Range(1, 256));
  sub->add_option("--ngf", a.ngf, "Overrides G's filters");
  sub->add_option("--ndf", a.ndf, "Overrides D's filters");
  sub->add_option("--depth", a.depth, "Overrides G's down-samplings (side must be a multiple of 2^depth)");
  sub->add_option("--epochs", a.epochs, "Overrides epochs at constant lr")->check(finite_in(0, 1e6));
  sub->add_option("--epochs-decay", a.epochs_decay, "Overrides epochs of linear lr decay")->check(finite_in(0, 1e6));
  sub->add_option("--batch-size", a.batch_size, "Overrides the batch size (per rank in a data-parallel job)")
      ->check(CLI::Range(1, 64));
  sub->add_option("--log-every", a.log_every, "Overrides the steps per log.csv row")->check(CLI::Range(1, 1000000000));
  sub->add_option("--nproc", a.nproc, "Start this many data-parallel ranks on this machine (loopback)")
      ->check(CLI::Range(1, 256));
  sub->add_option("--rank", a.dist.rank, "This process's rank (overrides RANK / SLURM_PROCID)")->check(CLI::Range(0, 4095));
  sub->add_option("--world-size", a.dist.world_size, "Ranks in the job (overrides WORLD_SIZE / SLURM_NTASKS)")
      ->check(CLI::Range(1, 4096));
  sub->add_option("--master-addr", a.dist.master_addr, "Host of rank 0's rendezvous store (overrides MASTER_ADDR)");
  sub->add_option("--master-port", a.dist.master_port, "Its TCP port (overrides MASTER_PORT; default 29500)")
      ->check(CLI::Range(1, 65535));
  sub->add_option("--dist-timeout", a.dist.timeout_s,
                  "Seconds before a silent rank fails the job (default 300; also the wait for all ranks to join)")
      ->check(finite_in(0.1, 86400));
  sub->add_flag("--no-verify", a.no_verify,
                "Skip checking the dataset's files against its manifest's checksums (paths and indexes are still checked)");
  sub->add_option("--bucket-mb", a.bucket_mb,
                  "Data-parallel: gradients all-reduced in buckets of this many MB as backward produces them")
      ->check(finite_in(1e-6, 1024));
  sub->add_option("--engine", a.engine, "Convolutions: onednn (default, faster) or torch (LibTorch's own)")
      ->check(CLI::IsMember({"onednn", "torch"}));
  sub->add_option("--precision", a.precision,
                  "Convolutions: fp32 (default), bf16 (fp32 master weights; fast with avx512_bf16/AMX) or auto")
      ->check(CLI::IsMember({"fp32", "bf16", "auto"}));
}

// The flags given override the config (and a resumed run's run.json).
nlohmann::json flag_overrides(const TrainArgs& a) {
  nlohmann::json flags = nlohmann::json::object();
  if (a.seed) flags["seed"] = *a.seed;
  if (a.threads) flags["threads"] = *a.threads;
  if (a.ngf) flags["ngf"] = *a.ngf;
  if (a.ndf) flags["ndf"] = *a.ndf;
  if (a.depth) flags["depth"] = *a.depth;
  if (a.epochs) flags["epochs"] = *a.epochs;
  if (a.epochs_decay) flags["epochs_decay"] = *a.epochs_decay;
  if (a.engine) flags["engine"] = *a.engine;
  if (a.precision) flags["precision"] = *a.precision;
  if (a.batch_size) flags["batch_size"] = *a.batch_size;
  if (a.log_every) flags["log_every"] = *a.log_every;
  return flags;
}

// Progress on stderr: a line redrawn in place on a terminal (tty); otherwise
// (a log file, a batch job) one line every 10 s (lines); log lines when `talk`.
void report_progress(train::RunOptions& run, bool tty, bool lines, bool talk) {
  auto last_line = std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
  run.on_step = [tty, lines, last_line](const train::StepReport& r) {
    if (!tty && !lines) return;
    const auto now = std::chrono::steady_clock::now();
    if (lines && now - *last_line < std::chrono::seconds(10) && r.step != 1 && r.step != r.total) return;
    *last_line = now;
    const double eta_min = r.seconds_per_step * double(r.total - r.step) / 60.0;
    std::fprintf(stderr, "%sstep %lld/%lld  G_GAN %.3f  G_L1 %.2f  D_real %.3f  D_fake %.3f  lr %.2e  %.2f s/it  ETA %.0f min%s",
                 tty ? "\r" : "train: ", static_cast<long long>(r.step), static_cast<long long>(r.total),
                 r.losses.g_gan, r.losses.g_l1, r.losses.d_real, r.losses.d_fake, r.lr, r.seconds_per_step, eta_min,
                 tty ? "   " : "\n");
    std::fflush(stderr);
  };
  run.on_log = [tty, talk](const std::string& s) {
    if (talk) std::fprintf(stderr, "%strain: %s\n", tty ? "\n" : "", s.c_str());
  };
}

int run_train(const TrainArgs& a, const GlobalOptions& g) {
  // Which rank of which job (torchrun, SLURM or flags); checked
  // before anything else so a bad environment writes nothing.
  const train::DistConfig dist = train::dist_config_from([](const char* k) { return std::getenv(k); }, a.dist);
  if (a.nproc > 1) {
    if (dist.world_size > 1)
      throw Error("--nproc starts its own ranks; drop it under torchrun/srun (" + dist.source + " says " +
                  std::to_string(dist.world_size) + " ranks)");
    const std::string& addr = a.dist.master_addr;
    if (!addr.empty() && addr != "localhost" && addr.rfind("127.", 0) != 0)
      throw Error("--master-addr " + addr + ": --nproc runs every rank on this machine over loopback; "
                  "drop --master-addr (or start the ranks with torchrun/srun)");
    return launch_ranks(a.nproc, std::max(a.dist.master_port, 0), g);
  }
  const train::TrainParams params = train::train_params_for_run(a.config, a.out, a.resume, flag_overrides(a));

  install_stop_handlers();
  train::follow_launcher();
  train::RunOptions run;
  run.data = a.data;
  run.out = a.out;
  run.resume = a.resume;
  run.init_from = a.init;
  run.max_steps = a.max_steps;
  run.stop = &stop_requested();
  run.dist = dist;
  run.bucket_mb = a.bucket_mb;
  run.verify_data = !a.no_verify;
  const bool lead = dist.rank == 0;  // the other ranks say nothing but errors
  const bool tty = !g.quiet && lead && ::isatty(2);
  report_progress(run, tty, !g.quiet && lead && !tty, !g.quiet && lead);
  const train::RunResult r = train::run_training(params, run);
  if (tty) std::fprintf(stderr, "\n");
  if (!lead) return r.interrupted ? 130 : 0;
  if (r.interrupted) {
    std::fprintf(stderr, "train: interrupted at step %lld of %lld; continue with --resume\n",
                 static_cast<long long>(r.step), static_cast<long long>(r.total));
    return 130;
  }
  std::printf("%s\n", (fs::path(a.out) / "generator.pt").c_str());
  return 0;
}

}  // namespace

Command add_train_command(CLI::App& app, const GlobalOptions& g) {
  auto* sub = app.add_subcommand(
      "train",
      "Train the pix2pix sketch-to-height model on a dataset\n\n"
      "Examples:\n"
      "  reefgen train --config configs/train/paper.json --data data/paper --out runs/paper\n"
      "  reefgen train --data data/small --out runs/try --max-steps 200 --ngf 32\n"
      "  reefgen train --data data/paper --out runs/paper --resume     # after Ctrl-C or a crash\n"
      "  reefgen train --config tuned.json --data data/paper --out runs/tuned --init runs/paper/checkpoint.pt\n"
      "  reefgen train --data data/paper --out runs/dp --nproc 2 --threads 1   # 2 data-parallel ranks here\n"
      "  torchrun --no_python --nnodes 4 --nproc_per_node 1 ... reefgen train --data ... --out ...\n"
      "Ctrl-C (SIGINT) or SIGTERM writes a checkpoint and RUN/generator.pt, then exits with 130.\n"
      "Under torchrun (RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT) or srun (SLURM_PROCID, SLURM_NTASKS,\n"
      "SLURM_JOB_NODELIST) each process is one rank of a data-parallel job; --batch-size is per rank\n"
      "(docs/TRAINING.md).\n");
  auto a = std::make_shared<TrainArgs>();
  add_train_options(sub, *a);
  return {sub, [a, &g]() -> int { return run_train(*a, g); }};
}

}  // namespace reefgen
