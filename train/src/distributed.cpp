#include "reefgen/train/distributed.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <csignal>
#include <cstring>
#include <thread>

#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <spawn.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <glog/logging.h>
#include <torch/csrc/autograd/utils/lambda_post_hook.h>
#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#include <torch/version.h>

#include "reefgen/files.hpp"
#include "reefgen/model/archive.hpp"

namespace reefgen::train {

namespace {

// Strict integer parse: the whole string, within [lo, hi].
int parse_int(const std::string& name, const std::string& v, long lo, long hi, const std::string& fix) {
  char* end = nullptr;
  errno = 0;
  const long x = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno || x < lo || x > hi)
    throw Error(name + "=" + v + ": not an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]; " + fix);
  return int(x);
}

// c10d and Gloo report through glog (socket time-outs, retries) on stderr;
// every such failure reaches the user as one line from us instead.
void quiet_c10d_logging() { FLAGS_minloglevel = google::GLOG_FATAL; }

// How long a connected store may take to answer the probe below: a real one
// answers in microseconds; an HTTP server waits for a request that never comes.
constexpr int kProbeAnswerMs = 5000;
// LibTorch 1.13's TCPStore protocol: the one-byte GETNUMKEYS query (its
// QueryType enum's 7th value), answered by an int64 count of keys. The wire
// format is LibTorch's private business: another version must be checked
// (torch/csrc/distributed/c10d/TCPStore.cpp) before this builds against it.
static_assert(TORCH_VERSION_MAJOR == 1 && TORCH_VERSION_MINOR == 13,
              "the store probe speaks LibTorch 1.13's TCPStore protocol (GETNUMKEYS = 6): check it against this "
              "version's TCPStore.cpp, then widen this assertion");
constexpr uint8_t kQueryGetNumKeys = 6;
// A key count no real store reaches; the first 8 bytes of an HTTP answer or
// an SSH banner read as an int64 are far above it.
constexpr int64_t kMaxPlausibleKeys = int64_t(1) << 32;

enum class StoreProbe { Store, Foreign, Unreachable };

struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

// One non-blocking connect to addr:port within timeout_ms; -1 on failure.
int connect_within(const addrinfo& ai, int timeout_ms) {
  const int fd = ::socket(ai.ai_family, ai.ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai.ai_protocol);
  if (fd < 0) return -1;
  if (::connect(fd, ai.ai_addr, ai.ai_addrlen) == 0) return fd;
  pollfd p{fd, POLLOUT, 0};
  int err = 0;
  socklen_t len = sizeof err;
  if (errno == EINPROGRESS && ::poll(&p, 1, timeout_ms) == 1 && ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len) == 0 &&
      err == 0)
    return fd;
  ::close(fd);
  return -1;
}

// Is addr:port a c10d rendezvous store? LibTorch's client trusts the length
// fields of what it reads, so a foreign service there (an HTTP server, an SSH
// banner, random bytes) makes it allocate without bound and abort the
// process; asked first, that service is named in one line instead. Connects
// until deadline (rank 0 may still be starting), then sends one GETNUMKEYS
// query and wants 8 bytes holding a plausible count within kProbeAnswerMs.
StoreProbe probe_store(const std::string& addr, int port, std::chrono::steady_clock::time_point deadline,
                       std::string* seen) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  if (::getaddrinfo(addr.c_str(), std::to_string(port).c_str(), &hints, &res) != 0 || !res) return StoreProbe::Unreachable;
  std::unique_ptr<addrinfo, decltype(&::freeaddrinfo)> hold(res, ::freeaddrinfo);
  Fd s;
  while (s.fd < 0) {
    for (addrinfo* ai = res; ai && s.fd < 0; ai = ai->ai_next) s.fd = connect_within(*ai, 1000);
    if (s.fd >= 0) break;
    if (std::chrono::steady_clock::now() >= deadline) return StoreProbe::Unreachable;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (::send(s.fd, &kQueryGetNumKeys, 1, MSG_NOSIGNAL) != 1) return StoreProbe::Foreign;
  unsigned char buf[8];
  size_t got = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(kProbeAnswerMs);
  while (got < sizeof buf) {
    const int left = int(std::chrono::duration_cast<std::chrono::milliseconds>(until - std::chrono::steady_clock::now()).count());
    pollfd p{s.fd, POLLIN, 0};
    if (left <= 0 || ::poll(&p, 1, left) != 1) {
      *seen = got ? "a partial answer" : "no answer within " + std::to_string(kProbeAnswerMs / 1000) + " s";
      return StoreProbe::Foreign;
    }
    const ssize_t n = ::recv(s.fd, buf + got, sizeof buf - got, 0);
    if (n <= 0) {
      *seen = "the connection closed";
      return StoreProbe::Foreign;
    }
    got += size_t(n);
  }
  int64_t keys = 0;
  std::memcpy(&keys, buf, sizeof keys);  // the store's native byte order (x86-64: little-endian)
  if (keys >= 0 && keys < kMaxPlausibleKeys) return StoreProbe::Store;
  std::string printable;
  for (unsigned char c : buf) printable += (c >= 32 && c < 127) ? char(c) : '.';
  *seen = "it answered \"" + printable + "...\"";
  return StoreProbe::Foreign;
}

std::string ranks_list(const std::vector<int>& r) {
  std::string s;
  for (size_t i = 0; i < r.size(); ++i) s += (i ? ", " : "") + std::to_string(r[i]);
  return s;
}

}  // namespace

std::string first_slurm_host(const std::string& nodelist) {
  // The first entry: up to a comma outside brackets.
  size_t depth = 0, end = nodelist.size();
  for (size_t i = 0; i < nodelist.size(); ++i) {
    if (nodelist[i] == '[') ++depth;
    if (nodelist[i] == ']' && depth) --depth;
    if (nodelist[i] == ',' && depth == 0) {
      end = i;
      break;
    }
  }
  const std::string first = nodelist.substr(0, end);
  const size_t open = first.find('[');
  if (open == std::string::npos) return first;
  const size_t close = first.find(']', open);
  if (close == std::string::npos) throw Error("SLURM_JOB_NODELIST=" + nodelist + ": unbalanced brackets; set MASTER_ADDR");
  // "03-05,09" -> "03" (zero padding kept: it is part of the host name)
  const std::string range = first.substr(open + 1, close - open - 1);
  const std::string lo = range.substr(0, range.find_first_of("-,"));
  return first.substr(0, open) + lo + first.substr(close + 1);
}

DistConfig dist_config_from(const std::function<const char*(const char*)>& getenv, const DistFlags& flags) {
  auto get = [&](const char* k) -> std::string {
    const char* v = getenv(k);
    return v ? std::string(v) : std::string();
  };
  DistConfig c;
  std::string rank_name = "RANK", world_name = "WORLD_SIZE", port_name = "MASTER_PORT";
  const std::string fix_env = "fix the launcher's environment or pass --rank/--world-size";
  if (!get("RANK").empty() || !get("WORLD_SIZE").empty()) {
    if (get("RANK").empty() || get("WORLD_SIZE").empty())
      throw Error(std::string(get("RANK").empty() ? "WORLD_SIZE" : "RANK") + " is set but " +
                  (get("RANK").empty() ? "RANK" : "WORLD_SIZE") + " is not; set both (torchrun does) or neither");
    c.source = get("REEFGEN_LAUNCHER_PID").empty() ? "torchrun's environment" : "train --nproc";
    c.world_size = parse_int("WORLD_SIZE", get("WORLD_SIZE"), 0, 4096, fix_env);
    c.rank = parse_int("RANK", get("RANK"), 0, 4095, fix_env);
    c.local_rank = get("LOCAL_RANK").empty() ? c.rank : parse_int("LOCAL_RANK", get("LOCAL_RANK"), 0, 4095, fix_env);
    c.local_world_size =
        get("LOCAL_WORLD_SIZE").empty() ? 1 : parse_int("LOCAL_WORLD_SIZE", get("LOCAL_WORLD_SIZE"), 1, 4096, fix_env);
    c.agent_store = get("TORCHELASTIC_USE_AGENT_STORE") == "True";
    if (!get("TORCHELASTIC_RESTART_COUNT").empty())
      c.restart_count = parse_int("TORCHELASTIC_RESTART_COUNT", get("TORCHELASTIC_RESTART_COUNT"), 0, 1 << 30, fix_env);
  } else if (!get("SLURM_PROCID").empty() && !get("SLURM_NTASKS").empty()) {
    c.source = "SLURM's environment";
    rank_name = "SLURM_PROCID";
    world_name = "SLURM_NTASKS";
    c.world_size = parse_int("SLURM_NTASKS", get("SLURM_NTASKS"), 0, 4096, "run under srun or pass --world-size");
    c.rank = parse_int("SLURM_PROCID", get("SLURM_PROCID"), 0, 4095, "run under srun or pass --rank");
    if (!get("SLURM_LOCALID").empty()) c.local_rank = parse_int("SLURM_LOCALID", get("SLURM_LOCALID"), 0, 4095, fix_env);
    // "2(x3),1" -> 2 tasks on the first node; ours may be another, but jobs are usually uniform.
    const std::string per = !get("SLURM_NTASKS_PER_NODE").empty() ? get("SLURM_NTASKS_PER_NODE") : get("SLURM_TASKS_PER_NODE");
    if (!per.empty()) c.local_world_size = std::max(1, std::atoi(per.c_str()));
    const std::string nodes = !get("SLURM_JOB_NODELIST").empty() ? get("SLURM_JOB_NODELIST") : get("SLURM_NODELIST");
    if (get("MASTER_ADDR").empty()) {
      if (nodes.empty()) throw Error("SLURM_JOB_NODELIST is not set; set MASTER_ADDR to the first node's host name");
      c.master_addr = first_slurm_host(nodes);
    }
  }
  if (!get("MASTER_ADDR").empty()) c.master_addr = get("MASTER_ADDR");
  if (!get("MASTER_PORT").empty())
    c.master_port = parse_int("MASTER_PORT", get("MASTER_PORT"), 1, 65535, "choose a free TCP port");
  if (flags.rank >= 0) c.rank = flags.rank, rank_name = "--rank";
  if (flags.world_size >= 0) c.world_size = flags.world_size, world_name = "--world-size";
  if (!flags.master_addr.empty()) c.master_addr = flags.master_addr;
  if (flags.master_port >= 0) c.master_port = flags.master_port, port_name = "--master-port";
  if (flags.timeout_s >= 0) c.timeout_s = flags.timeout_s;
  if (flags.rank >= 0 || flags.world_size >= 0) c.source = "the flags";
  if (c.world_size < 1)
    throw Error(world_name + "=" + std::to_string(c.world_size) + ": a job has at least one rank; " + fix_env);
  if (c.rank >= c.world_size)
    throw Error(rank_name + "=" + std::to_string(c.rank) + " with " + world_name + "=" + std::to_string(c.world_size) +
                ": ranks are 0.." + std::to_string(c.world_size - 1) + "; " + fix_env);
  if (c.master_port < 1 || c.master_port > 65535)
    throw Error(port_name + "=" + std::to_string(c.master_port) + ": not a TCP port; choose one in [1, 65535]");
  if (!(c.timeout_s > 0 && c.timeout_s <= 86400))
    throw Error("--dist-timeout " + std::to_string(c.timeout_s) + ": must be in (0, 86400] seconds");
  if (c.local_rank >= c.local_world_size) c.local_world_size = c.local_rank + 1;
  return c;
}

// ---------------------------------------------------------------------------

// Liveness, apart from --dist-timeout (which bounds slow collectives): every
// rank bumps its heartbeat twice a second from its own thread, busy or not,
// so a counter that has not moved for this long means a stopped (SIGSTOP),
// hung or dead process. Well under the bar of 60 s, far above any
// scheduling hiccup.
constexpr double kLivenessDeadlineS = 20;
// The watchdog's store reads: a stopped host answers nothing at all.
constexpr auto kWatchdogReadTimeout = std::chrono::milliseconds(4000);

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
  void watch(const DistConfig& cfg) {
    using clock = std::chrono::steady_clock;
    const int n = cfg.world_size;
    std::vector<int64_t> last(size_t(n), -1);
    std::vector<clock::time_point> moved(size_t(n), clock::now());
    auto store_answered = clock::now();
    c10::intrusive_ptr<c10d::Store> s;
    auto lost = [&](const std::string& who) {
      std::fprintf(stderr, "reefgen: error: rank %d: %s; the job is stopped\n", cfg.rank, who.c_str());
      std::fflush(stderr);
      std::_Exit(1);
    };
    while (!stop) {
      for (int i = 0; i < 10 && !stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
      if (stop) break;
      const auto now = clock::now();
      try {
        if (!s) s = client(cfg, false, kWatchdogReadTimeout);
        for (int r = 0; r < n; ++r) {
          if (r == cfg.rank) continue;
          const int64_t hb = s->add("hb/" + std::to_string(r), 0);
          if (hb != last[size_t(r)]) last[size_t(r)] = hb, moved[size_t(r)] = now;
          if (std::chrono::duration<double>(now - moved[size_t(r)]).count() > kLivenessDeadlineS &&
              !s->check({"left/" + std::to_string(r)}) && !stop)
            lost("rank " + std::to_string(r) + " sent no heartbeat for " + std::to_string(int(kLivenessDeadlineS)) +
                 " s (stopped, hung or killed)");
        }
        store_answered = now;
      } catch (const std::exception&) {
        s.reset();
        std::string seen;
        // Refused: the host is gone, and the collectives fail on their own.
        if (probe_store(cfg.master_addr, cfg.master_port, clock::now(), &seen) == StoreProbe::Unreachable) return;
        if (std::chrono::duration<double>(clock::now() - store_answered).count() > kLivenessDeadlineS && !stop)
          lost(std::string(cfg.agent_store ? "the launcher's rendezvous store" : "rank 0 (which hosts the rendezvous store)") +
               " stopped answering for " + std::to_string(int(kLivenessDeadlineS)) + " s (stopped or hung)");
      }
    }
  }

  c10::intrusive_ptr<c10d::Store> client(const DistConfig& c, bool server, std::chrono::milliseconds timeout) const {
    c10d::TCPStoreOptions so;
    so.port = uint16_t(c.master_port);
    so.isServer = server;
    so.waitWorkers = false;
    so.timeout = timeout;
    return c10::make_intrusive<c10d::PrefixStore>(prefix, c10::make_intrusive<c10d::TCPStore>(c.master_addr, so));
  }
};

Comm::Comm(const DistConfig& cfg) : cfg_(cfg), impl_(std::make_unique<Impl>()) {}

Comm::~Comm() {
  if (!impl_) return;
  impl_->stop = true;
  try {  // not waited for by the others' watchdogs from now on
    if (impl_->store) impl_->store->set("left/" + std::to_string(cfg_.rank), std::vector<uint8_t>{1});
  } catch (...) {
  }
  if (impl_->watchdog.joinable()) impl_->watchdog.join();
  if (impl_->heartbeat.joinable()) impl_->heartbeat.join();
}

std::unique_ptr<Comm> Comm::connect(const DistConfig& cfg) {
  quiet_c10d_logging();
  std::unique_ptr<Comm> c(new Comm(cfg));
  Impl& m = *c->impl_;
  const auto timeout = std::chrono::milliseconds(int64_t(cfg.timeout_s * 1000));
  const std::string where = cfg.master_addr + ":" + std::to_string(cfg.master_port);
  const std::string me = "rank " + std::to_string(cfg.rank);
  // torchrun's agent store serves every attempt; keys of this one live under its prefix.
  m.prefix = (cfg.agent_store ? "/worker/attempt_" + std::to_string(cfg.restart_count) + "/" : std::string()) + "reefgen/";
  const bool host = cfg.rank == 0 && !cfg.agent_store;
  if (!host) {
    std::string seen;
    const auto probe = probe_store(cfg.master_addr, cfg.master_port, std::chrono::steady_clock::now() + timeout, &seen);
    if (probe == StoreProbe::Foreign)
      throw Error(me + ": " + where + " (from " + cfg.source + ") is another service, not a rendezvous store (" + seen +
                  "); set MASTER_PORT (--master-port) to the port rank 0 hosts");
    if (probe == StoreProbe::Unreachable)
      throw Error(me + ": cannot reach the rendezvous store at " + where + " within " +
                  std::to_string(int(cfg.timeout_s)) + " s (from " + cfg.source +
                  "); start rank 0 first, or fix MASTER_ADDR/MASTER_PORT (--master-addr/--master-port)");
  }
  try {
    m.store = m.client(cfg, host, timeout);
  } catch (const std::exception& e) {
    if (host)
      throw Error(me + ": cannot host the rendezvous store on " + where + " (" + model::first_line(e.what()) +
                  "); choose a free MASTER_PORT (or --master-port)");
    throw Error(me + ": cannot reach the rendezvous store at " + where + " within " + std::to_string(int(cfg.timeout_s)) +
                " s (from " + cfg.source + "); start rank 0 first, or fix MASTER_ADDR/MASTER_PORT (--master-addr/--master-port)");
  }
  // Liveness: every rank bumps its counter twice a second on its own
  // connection, so a failed collective can tell a dead or stopped peer.
  try {
    auto hb = m.client(cfg, false, timeout);
    m.store->set("joined/" + std::to_string(cfg.rank), std::vector<uint8_t>{1});
    m.heartbeat = std::thread([&m, hb, r = cfg.rank] {
      try {
        while (!m.stop) {
          hb->add("hb/" + std::to_string(r), 1);
          for (int i = 0; i < 5 && !m.stop; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
        }
      } catch (...) {  // the store is gone: the next collective reports it
      }
    });
  } catch (const std::exception& e) {
    throw Error(me + ": the rendezvous store at " + where + " stopped answering (" + model::first_line(e.what()) + ")");
  }
  try {
    auto opts = c10d::ProcessGroupGloo::Options::create(timeout);
    const char* ifname = std::getenv("GLOO_SOCKET_IFNAME");
    const bool loopback = cfg.master_addr == "localhost" || cfg.master_addr.rfind("127.", 0) == 0;
    if (ifname && *ifname)
      opts->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(ifname));
    else if (loopback)
      opts->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
    else
      opts->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    m.pg = c10::make_intrusive<c10d::ProcessGroupGloo>(m.store, cfg.rank, cfg.world_size, opts);
  } catch (const std::exception& e) {
    std::vector<int> missing;
    try {
      for (int r = 0; r < cfg.world_size; ++r)
        if (!m.store->check({"joined/" + std::to_string(r)})) missing.push_back(r);
    } catch (...) {
    }
    if (!missing.empty())
      throw Error(me + ": rank" + (missing.size() > 1 ? "s " : " ") + ranks_list(missing) + " did not join within " +
                  std::to_string(int(cfg.timeout_s)) + " s; start all " + std::to_string(cfg.world_size) +
                  " ranks with the same MASTER_ADDR:MASTER_PORT (" + where + ")");
    throw Error(me + ": cannot connect to the other ranks (" + model::first_line(e.what()) +
                "); check that the hosts reach each other (GLOO_SOCKET_IFNAME names the interface)");
  }
  m.watchdog = std::thread([&m, cfg] { m.watch(cfg); });
  return c;
}

void Comm::fail(const std::string& what, const std::exception& e) {
  const std::string me = "rank " + std::to_string(cfg_.rank);
  // Who stopped? Read every rank's heartbeat twice, 2 s apart, on a fresh
  // connection (ours may be the one that broke).
  std::vector<int> silent;
  try {
    auto s = impl_->client(cfg_, false, std::chrono::milliseconds(5000));
    std::vector<int64_t> before(size_t(cfg_.world_size));
    for (int r = 0; r < cfg_.world_size; ++r) before[size_t(r)] = s->add("hb/" + std::to_string(r), 0);
    std::this_thread::sleep_for(std::chrono::seconds(2));
    for (int r = 0; r < cfg_.world_size; ++r)
      if (r != cfg_.rank && s->add("hb/" + std::to_string(r), 0) == before[size_t(r)]) silent.push_back(r);
  } catch (const std::exception&) {
    if (!cfg_.agent_store && cfg_.rank != 0)
      throw Error(me + ": rank 0 (which hosts the rendezvous store) is gone (killed or crashed) during " + what +
                  "; the job is stopped");
    throw Error(me + ": the rendezvous store at " + cfg_.master_addr + ":" + std::to_string(cfg_.master_port) +
                " is gone during " + what + "; the job is stopped");
  }
  if (!silent.empty())
    throw Error(me + ": rank" + (silent.size() > 1 ? "s " : " ") + ranks_list(silent) +
                " stopped answering (killed or hung) during " + what + "; the job is stopped (" +
                model::first_line(e.what()) + ")");
  throw Error(me + ": " + what + " failed: " + model::first_line(e.what()));
}

namespace {
template <class F>
double timed(F f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

void Comm::broadcast(std::vector<torch::Tensor> tensors, const std::string& what) {
  try {
    seconds_ += timed([&] {
      c10d::BroadcastOptions o;
      o.rootRank = 0;
      for (auto& t : tensors) {
        std::vector<at::Tensor> one = {t};
        impl_->pg->broadcast(one, o)->wait();
      }
    });
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(what, e);
  }
}

std::string Comm::broadcast_string(const std::string& s, const std::string& what) {
  torch::Tensor n = torch::tensor({int64_t(s.size())}, torch::kInt64);
  broadcast({n}, what);
  torch::Tensor bytes = torch::zeros({n.item<int64_t>()}, torch::kUInt8);
  if (rank() == 0) std::memcpy(bytes.data_ptr(), s.data(), s.size());
  if (bytes.numel()) broadcast({bytes}, what);
  return std::string(static_cast<const char*>(bytes.data_ptr()), size_t(bytes.numel()));
}

void Comm::allreduce_sum(std::vector<torch::Tensor> tensors, const std::string& what) {
  try {
    seconds_ += timed([&] {
      for (auto& t : tensors) {
        std::vector<at::Tensor> one = {t};
        impl_->pg->allreduce(one)->wait();
      }
    });
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    fail(what, e);
  }
}

struct GradientReducer::State {
  Comm& comm;
  std::vector<torch::Tensor> params;
  std::string what;
  int64_t cap;  // floats per bucket
  // The accumulators must live as long as the hooks: a parameter keeps only
  // a weak reference to its own.
  std::vector<std::shared_ptr<torch::autograd::Node>> accumulators;
  std::vector<uintptr_t> hook_keys;
  bool armed = false;
  std::vector<int64_t> observed;            // first step: ready order on this rank
  std::vector<std::vector<size_t>> buckets;  // parameter indices, in launch order
  std::vector<int> bucket_of;                // parameter -> bucket
  std::vector<int> missing;                  // per bucket: gradients not in yet
  size_t next = 0;                           // next bucket to launch
  struct InFlight {
    size_t bucket;
    torch::Tensor flat;
    c10::intrusive_ptr<c10d::Work> work;
  };
  std::vector<InFlight> in_flight;
  State(Comm& c, std::vector<torch::Tensor> p, std::string w, int64_t k)
      : comm(c), params(std::move(p)), what(std::move(w)), cap(k) {}

  void launch(size_t b) {
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<torch::Tensor> views;
    for (size_t i : buckets[b]) {
      const torch::Tensor& g = params[i].grad();
      views.push_back(g.defined() ? g.reshape({-1}) : torch::zeros({params[i].numel()}, params[i].options()));
    }
    // A gradient as large as a bucket travels in place (no packing and
    // unpacking passes over it); smaller ones are packed together.
    const torch::Tensor& g0 = params[buckets[b][0]].grad();
    const bool in_place = buckets[b].size() == 1 && g0.defined() && g0.is_contiguous();
    InFlight f{b, in_place ? g0.view({-1}) : torch::cat(views), {}};  // {bucket floats}
    std::vector<at::Tensor> one = {f.flat};
    f.work = comm.impl_->pg->allreduce(one);
    in_flight.push_back(std::move(f));
    comm.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  void ready(size_t i) {
    if (!armed) return;
    if (buckets.empty()) {
      observed.push_back(int64_t(i));
      return;
    }
    const int b = bucket_of[i];
    if (b < 0 || --missing[size_t(b)] > 0) return;
    while (next < buckets.size() && missing[next] <= 0) launch(next++);
  }
  void plan(const std::vector<int64_t>& order) {
    bucket_of.assign(params.size(), -1);
    int64_t n = 0;
    for (int64_t i : order) {
      if (i < 0) continue;
      if (buckets.empty() || n + params[size_t(i)].numel() > cap) {
        buckets.emplace_back();
        n = 0;
      }
      buckets.back().push_back(size_t(i));
      bucket_of[size_t(i)] = int(buckets.size() - 1);
      n += params[size_t(i)].numel();
    }
  }
};

GradientReducer::GradientReducer(Comm& comm, std::vector<torch::Tensor> params, std::string what, double bucket_mb)
    : s_(std::make_unique<State>(comm, std::move(params), std::move(what),
                                 std::max<int64_t>(1, int64_t(bucket_mb * 1e6 / 4)))) {
  State* st = s_.get();
  for (size_t i = 0; i < st->params.size(); ++i) {
    auto acc = torch::autograd::impl::grad_accumulator(st->params[i]);
    st->hook_keys.push_back(acc->add_post_hook(std::make_unique<torch::autograd::utils::LambdaPostHook>(
        [st, i](const torch::autograd::variable_list& outputs, const torch::autograd::variable_list&) {
          st->ready(i);  // the gradient is in params[i].grad() now
          return outputs;
        })));
    st->accumulators.push_back(std::move(acc));
  }
}

GradientReducer::~GradientReducer() {
  for (size_t i = 0; i < s_->accumulators.size(); ++i) s_->accumulators[i]->del_post_hook(s_->hook_keys[i]);
}

void GradientReducer::begin() {
  State& st = *s_;
  st.armed = true;
  st.next = 0;
  st.in_flight.clear();
  st.missing.assign(st.buckets.size(), 0);
  for (size_t b = 0; b < st.buckets.size(); ++b) st.missing[b] = int(st.buckets[b].size());
}

void GradientReducer::end() {
  State& st = *s_;
  Comm& comm = st.comm;
  st.armed = false;
  if (comm.world_size() == 1) return;
  try {
    if (st.buckets.empty()) {  // the first step: adopt rank 0's ready order
      torch::Tensor order = torch::full({int64_t(st.params.size())}, int64_t(-1), torch::kInt64);
      for (size_t k = 0; k < st.observed.size() && k < st.params.size(); ++k) order[int64_t(k)] = st.observed[k];
      std::vector<at::Tensor> one = {order};
      c10d::BroadcastOptions o;
      comm.impl_->pg->broadcast(one, o)->wait();
      std::vector<int64_t> v(order.data_ptr<int64_t>(), order.data_ptr<int64_t>() + order.numel());
      // Parameters that got no gradient on rank 0 still travel, last.
      std::vector<bool> seen(st.params.size(), false);
      for (int64_t i : v)
        if (i >= 0) seen[size_t(i)] = true;
      for (size_t i = 0; i < st.params.size(); ++i)
        if (!seen[i]) v.push_back(int64_t(i));
      st.plan(v);
      st.observed.clear();
      st.next = 0;
      st.missing.assign(st.buckets.size(), 0);
    }
    while (st.next < st.buckets.size()) st.launch(st.next++);  // what backward did not complete
    const auto t0 = std::chrono::steady_clock::now();
    const double inv = 1.0 / double(comm.world_size());
    for (auto& f : st.in_flight) {
      f.work->wait();
      f.flat.mul_(inv);
      const torch::Tensor& g0 = st.params[st.buckets[f.bucket][0]].grad();
      if (g0.defined() && g0.data_ptr() == f.flat.data_ptr()) continue;  // reduced in place
      int64_t off = 0;
      for (size_t i : st.buckets[f.bucket]) {
        torch::Tensor& p = st.params[i];
        const int64_t n = p.numel();
        if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
        p.mutable_grad().copy_(f.flat.narrow(0, off, n).view_as(p));
        off += n;
      }
    }
    st.in_flight.clear();
    comm.seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    st.in_flight.clear();
    comm.fail(st.what, e);
  }
}

namespace {
// sum over ranks; backward: the sum over ranks of the incoming gradients
// (each rank's loss depends on every rank's input through the sum).
struct ReplicaSumFn : torch::autograd::Function<ReplicaSumFn> {
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x, int64_t comm) {
    ctx->saved_data["comm"] = comm;
    torch::Tensor y = x.detach().contiguous().clone();
    reinterpret_cast<Comm*>(comm)->allreduce_sum({y}, "the synchronised BatchNorm statistics");
    return y;
  }
  static torch::autograd::variable_list backward(torch::autograd::AutogradContext* ctx,
                                                 torch::autograd::variable_list g) {
    Comm* comm = reinterpret_cast<Comm*>(ctx->saved_data["comm"].toInt());
    torch::Tensor gx = g[0].contiguous().clone();
    comm->allreduce_sum({gx}, "the synchronised BatchNorm gradients");
    return {gx, torch::Tensor()};
  }
};
}  // namespace

torch::Tensor Comm::replica_sum(const torch::Tensor& x) {
  return ReplicaSumFn::apply(x, reinterpret_cast<int64_t>(this));
}

double Comm::take_collective_seconds() {
  const double s = seconds_;
  seconds_ = 0;
  return s;
}

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
