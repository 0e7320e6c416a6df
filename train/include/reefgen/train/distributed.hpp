#pragma once
// Data-parallel training over c10d/Gloo (docs/TRAINING.md, "More than one
// machine"): where a rank learns who it is (torchrun, SLURM or flags), and
// the few collectives the trainer needs. Every rank holds the whole of G and
// D; each step it trains on its slice of the global batch, BatchNorm
// statistics are summed over the ranks, gradients are averaged, and all
// ranks apply the same Adam update, so they never drift apart.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <torch/torch.h>

namespace reefgen::train {

struct DistConfig {
  int rank = 0;                 // this process, [0, world_size)
  int world_size = 1;           // processes in the job, [1, 4096]
  int local_rank = 0;           // this process on its machine
  int local_world_size = 1;     // processes on this machine (threads per rank = cores / this)
  std::string master_addr = "127.0.0.1";  // host of the rendezvous store (rank 0's, or torchrun's agent)
  int master_port = 29500;      // its TCP port, [1, 65535]
  // torchrun's TORCHELASTIC_USE_AGENT_STORE: the agent already hosts the
  // store, every rank connects as a client under the attempt's prefix.
  bool agent_store = false;
  int restart_count = 0;        // TORCHELASTIC_RESTART_COUNT (the store prefix of this attempt)
  double timeout_s = 300;       // a rank that does not answer for this long fails the job, (0, 86400]
  std::string source = "single process";  // where the above came from, for messages
};

// The flags of `reefgen train` that override the environment (unset = -1 / empty).
struct DistFlags {
  int rank = -1, world_size = -1, master_port = -1;
  std::string master_addr;
  double timeout_s = -1;
};

// Reads torchrun's (RANK, WORLD_SIZE, LOCAL_RANK, LOCAL_WORLD_SIZE,
// MASTER_ADDR, MASTER_PORT, TORCHELASTIC_*), else SLURM's (SLURM_PROCID,
// SLURM_NTASKS, SLURM_LOCALID, SLURM_NTASKS_PER_NODE, the first host of
// SLURM_JOB_NODELIST), then applies the flags. `getenv` is injectable for
// tests. Throws reefgen::Error with one line naming the variable and the fix.
DistConfig dist_config_from(const std::function<const char*(const char*)>& getenv, const DistFlags& flags = {});
// The first host of a SLURM node list: "node[03-05,09],gpu1" -> "node03".
std::string first_slurm_host(const std::string& nodelist);

// One rank's membership in the job. All ranks must call the collectives in
// the same order. A peer that dies or hangs makes the next collective throw
// reefgen::Error naming the rank (a heartbeat in the store tells who), within
// `timeout_s`.
class Comm {
 public:
  static std::unique_ptr<Comm> connect(const DistConfig& cfg);  // waits for every rank (up to timeout_s)
  ~Comm();
  int rank() const { return cfg_.rank; }
  int world_size() const { return cfg_.world_size; }
  const DistConfig& config() const { return cfg_; }

  // Rank 0's tensors overwrite everyone's (in place).
  void broadcast(std::vector<torch::Tensor> tensors, const std::string& what);
  // Rank 0's string, everywhere.
  std::string broadcast_string(const std::string& s, const std::string& what);
  // In place: the sum over ranks (float32 or float64 tensors).
  void allreduce_sum(std::vector<torch::Tensor> tensors, const std::string& what);
  // The differentiable sum over ranks (model::ReplicaSum) for synchronised BatchNorm.
  torch::Tensor replica_sum(const torch::Tensor& x);

  // Seconds spent inside collectives since the last call (the log's allreduce_s).
  double take_collective_seconds();

  struct Impl;

 private:
  friend class GradientReducer;
  explicit Comm(const DistConfig& cfg);
  [[noreturn]] void fail(const std::string& what, const std::exception& e);
  DistConfig cfg_;
  std::unique_ptr<Impl> impl_;
  double seconds_ = 0;
};

// Averages the gradients of `params` over the ranks while backward is still
// running: every parameter's gradient accumulator gets a hook, and once all
// gradients of a bucket (about `bucket_mb`) are in, the bucket is packed and
// its all-reduce starts on Gloo's threads as backward goes on. Buckets
// follow the order in which gradients became ready on rank 0 in the first
// step (broadcast, so every rank issues the same collectives in the same
// order); that first step all-reduces after backward.
class GradientReducer {
 public:
  GradientReducer(Comm& comm, std::vector<torch::Tensor> params, std::string what, double bucket_mb = 4);
  ~GradientReducer();
  GradientReducer(const GradientReducer&) = delete;
  GradientReducer& operator=(const GradientReducer&) = delete;
  void begin();  // before backward
  void end();    // after backward: every gradient is the mean over the ranks

 private:
  struct State;
  std::unique_ptr<State> s_;
};

// `reefgen train --nproc N`: N ranks of `exe args…` on this machine, on
// loopback. This process hosts the rendezvous store (as torchrun's agent
// does: TORCHELASTIC_USE_AGENT_STORE), so it outlives any rank and the
// survivors can tell which one died. Each rank gets torchrun's variables.
// Returns 0 when every rank ends with 0 and 130 when they were interrupted
// (`stop` set: SIGTERM forwarded, checkpoints written); when a rank fails,
// stops the others and throws reefgen::Error naming the first that failed.
struct LocalLaunch {
  std::string exe;                 // the program every rank runs
  std::vector<std::string> args;   // its arguments (without argv[0])
  int nproc = 2;                   // ranks, [2, 256]
  int port = 0;                    // the rendezvous store's TCP port on 127.0.0.1; 0: any free one
  double grace_s = 10;             // after a failure: SIGTERM, then SIGKILL after this long
  const std::atomic<bool>* stop = nullptr;
  std::function<void(const std::string&)> on_log;
};
// Each rank gets REEFGEN_LAUNCHER_PID: see follow_launcher().
int launch_local_ranks(const LocalLaunch& l);
// In a rank started by launch_local_ranks (REEFGEN_LAUNCHER_PID set): asks
// the kernel for SIGTERM when the launcher dies (kill -9, SIGHUP), so no rank
// trains on as an orphan holding the run folder; throws if it is gone
// already. Does nothing outside such a launch.
void follow_launcher();

}  // namespace reefgen::train
