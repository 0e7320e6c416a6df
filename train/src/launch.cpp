// `train --nproc N`: the local launcher (torchrun's agent on one machine)
// and the ranks' side of it.
#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <spawn.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include "dist_internal.hpp"
#include "reefgen/model/archive.hpp"

namespace reefgen::train {

using detail::parse_int;
using detail::quiet_c10d_logging;

void follow_launcher() {
  const char* v = std::getenv("REEFGEN_LAUNCHER_PID");
  if (!v || !*v) return;
  const pid_t launcher = pid_t(parse_int("REEFGEN_LAUNCHER_PID", v, 1, 1L << 30, "it is set by `train --nproc`; unset it"));
  // SIGTERM: the rank stops as on Ctrl-C (checkpoint after the step, exit).
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);
  // The launcher may have died before the line above: then it never fires.
  if (::getppid() != launcher)
    throw Error("rank " + std::string(std::getenv("RANK") ? std::getenv("RANK") : "?") +
                ": its `train --nproc` launcher (pid " + v + ") is gone; the job is stopped");
}

namespace {

// The rendezvous store the ranks meet at, hosted by the launcher on
// 127.0.0.1 (port 0: any free one).
c10::intrusive_ptr<c10d::TCPStore> host_store(int port) {
  if (port < 0 || port > 65535) throw Error("--master-port " + std::to_string(port) + ": not a TCP port");
  c10d::TCPStoreOptions so;
  so.port = uint16_t(port);
  so.isServer = true;
  so.waitWorkers = false;
  try {
    return c10::make_intrusive<c10d::TCPStore>("127.0.0.1", so);
  } catch (const std::exception& e) {
    if (port)
      throw Error("--master-port " + std::to_string(port) + ": cannot host the rendezvous store on 127.0.0.1:" +
                  std::to_string(port) + " (" + model::first_line(e.what()) + "); choose a free port or drop --master-port");
    throw Error("--nproc: cannot host the rendezvous store on 127.0.0.1 (" + model::first_line(e.what()) + ")");
  }
}

// The launcher's environment without the variables that say which rank of
// which job a process is (each rank gets its own below).
std::vector<std::string> environment_without_rank() {
  const char* ours[] = {"RANK=", "WORLD_SIZE=", "LOCAL_RANK=", "LOCAL_WORLD_SIZE=", "MASTER_ADDR=", "MASTER_PORT=",
                        "TORCHELASTIC_USE_AGENT_STORE=", "TORCHELASTIC_RESTART_COUNT=", "SLURM_PROCID=", "SLURM_NTASKS=",
                        "REEFGEN_LAUNCHER_PID="};
  std::vector<std::string> env;
  for (char** e = ::environ; *e; ++e) {
    bool drop = false;
    for (const char* k : ours) drop = drop || std::strncmp(*e, k, std::strlen(k)) == 0;
    if (!drop) env.push_back(*e);
  }
  return env;
}

// torchrun's variables for rank r of n on this machine, meeting at `port`.
std::vector<std::string> rank_environment(std::vector<std::string> env, int r, int n, const std::string& port) {
  for (const std::string& kv : {"RANK=" + std::to_string(r), "WORLD_SIZE=" + std::to_string(n),
                                "LOCAL_RANK=" + std::to_string(r), "LOCAL_WORLD_SIZE=" + std::to_string(n),
                                std::string("MASTER_ADDR=127.0.0.1"), "MASTER_PORT=" + port,
                                std::string("TORCHELASTIC_USE_AGENT_STORE=True"),
                                std::string("TORCHELASTIC_RESTART_COUNT=0"),
                                "REEFGEN_LAUNCHER_PID=" + std::to_string(::getpid())})
    env.push_back(kv);
  return env;
}

// The launcher's children, one per rank, and what became of them.
struct RankProcesses {
  std::vector<pid_t> pids;
  std::vector<bool> done;
  explicit RankProcesses(int n) : pids(size_t(n), -1), done(size_t(n), false) {}

  void signal_all(int sig) const {
    for (size_t r = 0; r < pids.size(); ++r)
      if (pids[r] > 0 && !done[r]) ::kill(pids[r], sig);
  }
  // Starts `exe args` as rank r; on failure stops the ranks already started.
  void spawn(int r, const std::string& exe, std::vector<std::string> args, std::vector<std::string> env) {
    std::vector<char*> envp, argv;
    for (auto& e : env) envp.push_back(e.data());
    envp.push_back(nullptr);
    std::string path = exe;
    argv.push_back(path.data());
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = -1;
    const int err = ::posix_spawn(&pid, path.c_str(), nullptr, nullptr, argv.data(), envp.data());
    if (err) {
      signal_all(SIGTERM);
      for (pid_t q : pids)
        if (q > 0) ::waitpid(q, nullptr, 0);
      throw Error(exe + ": cannot start rank " + std::to_string(r) + " (" + std::strerror(err) + ")");
    }
    pids[size_t(r)] = pid;
  }
  // The rank a finished child was, or -1 for a child that is not a rank.
  int rank_of(pid_t pid) const {
    const auto it = std::find(pids.begin(), pids.end(), pid);
    return it == pids.end() ? -1 : int(it - pids.begin());
  }
};

// What a rank's exit status says went wrong ("" for success or Ctrl-C's 130).
std::string rank_failure(int r, int status) {
  if (WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 130)) return "";
  if (WIFSIGNALED(status))
    return "rank " + std::to_string(r) + " was killed by signal " + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  return "rank " + std::to_string(r) + " failed with exit code " + std::to_string(WEXITSTATUS(status));
}

}  // namespace

// torchrun's job on one machine: host the store, start the ranks, then wait
// for all of them. The first rank to fail stops the others (SIGTERM, then
// SIGKILL after the grace period); Ctrl-C is forwarded once, so every rank
// checkpoints after the same step.
int launch_local_ranks(const LocalLaunch& l) {
  if (l.nproc < 2 || l.nproc > 256) throw Error("--nproc " + std::to_string(l.nproc) + ": must be in [2, 256]");
  quiet_c10d_logging();
  const c10::intrusive_ptr<c10d::TCPStore> store = host_store(l.port);
  const std::string port = std::to_string(store->getPort());
  const std::vector<std::string> base_env = environment_without_rank();
  RankProcesses ranks(l.nproc);
  for (int r = 0; r < l.nproc; ++r) {
    ranks.spawn(r, l.exe, l.args, rank_environment(base_env, r, l.nproc, port));
    if (l.on_log) l.on_log("rank " + std::to_string(r) + ": pid " + std::to_string(ranks.pids[size_t(r)]));
  }
  std::string failure;
  bool interrupted = false, forwarded = false;
  int remaining = l.nproc;
  auto failed_at = std::chrono::steady_clock::time_point{};
  while (remaining > 0) {
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, WNOHANG);
    if (pid > 0) {
      const int r = ranks.rank_of(pid);
      if (r < 0) continue;
      ranks.done[size_t(r)] = true;
      --remaining;
      interrupted = interrupted || (WIFEXITED(status) && WEXITSTATUS(status) == 130);
      if (failure.empty() && !(failure = rank_failure(r, status)).empty()) {
        ranks.signal_all(SIGTERM);
        failed_at = std::chrono::steady_clock::now();
      }
      continue;
    }
    if (l.stop && l.stop->load() && !forwarded) {
      ranks.signal_all(SIGTERM);
      forwarded = true;
    }
    if (!failure.empty() &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - failed_at).count() > l.grace_s)
      ranks.signal_all(SIGKILL);
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!failure.empty()) throw Error(failure + "; the other ranks were stopped (its own message is above)");
  return interrupted ? 130 : 0;
}


}  // namespace reefgen::train
