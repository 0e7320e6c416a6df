// Internal to train/: what the data-parallel files share (the rendezvous
// store probe, the strict integer parse, the communicator's state). Not
// installed; the public interface is reefgen/train/distributed.hpp.
#pragma once

#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/Store.hpp>

#include "reefgen/error.hpp"
#include "reefgen/train/distributed.hpp"

namespace reefgen::train::detail {

// Strict integer parse: the whole string, within [lo, hi]; else reefgen::Error
// naming the variable and `fix`.
int parse_int(const std::string& name, const std::string& v, long lo, long hi, const std::string& fix);

// "1, 3, 4".
std::string ranks_list(const std::vector<int>& r);

// c10d and Gloo report through glog (socket time-outs, retries) on stderr;
// every such failure reaches the user as one line from us instead.
void quiet_c10d_logging();

enum class StoreProbe { Store, Foreign, Unreachable };

// Is addr:port a c10d rendezvous store? (store_probe.cpp). On Foreign,
// `seen` says what answered.
StoreProbe probe_store(const std::string& addr, int port, std::chrono::steady_clock::time_point deadline,
                       std::string* seen);

}  // namespace reefgen::train::detail

namespace reefgen::train {

// Liveness, apart from --dist-timeout (which bounds slow collectives): every
// rank bumps its heartbeat twice a second from its own thread, busy or not,
// so a counter that has not moved for this long means a stopped (SIGSTOP),
// hung or dead process. Well under the bar of 60 s, far above any
// scheduling hiccup.
constexpr double kLivenessDeadlineS = 20;

// The communicator's state: the job's store, Gloo's process group, and the
// heartbeat and watchdog threads (comm.cpp). GradientReducer launches its
// all-reduces on `pg` directly.
struct Comm::Impl {
  c10::intrusive_ptr<c10d::Store> store;  // the job's keys (prefixed)
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;
  std::thread heartbeat, watchdog;
  std::atomic<bool> stop{false};
  std::string prefix;

  // Watches the other ranks' heartbeats while the main thread may sit in a
  // collective LibTorch 1.13 cannot cancel: a silent peer (or a store host
  // that stopped answering) ends this process with one line, so the job ends
  // within kLivenessDeadlineS whatever --dist-timeout allows collectives.
  // A rank that leaves normally marks "left/R" first and is not waited for.
  void watch(const DistConfig& cfg);
  // A client (or, with `server`, the host) of the job's store, under `prefix`.
  c10::intrusive_ptr<c10d::Store> client(const DistConfig& c, bool server, std::chrono::milliseconds timeout) const;
};

}  // namespace reefgen::train
