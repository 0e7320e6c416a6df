// The communicator: rendezvous, Gloo's process group, broadcast and
// all-reduce with one-line failures, and the heartbeat and watchdog threads
// that end a job whose peer stopped (docs/TRAINING.md "Data-parallel").
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>

#include "dist_internal.hpp"
#include "reefgen/model/archive.hpp"

namespace reefgen::train {

using detail::probe_store;
using detail::ranks_list;
using detail::quiet_c10d_logging;
using detail::StoreProbe;

namespace {
// The watchdog's store reads: a stopped host answers nothing at all.
constexpr auto kWatchdogReadTimeout = std::chrono::milliseconds(4000);
}  // namespace

void Comm::Impl::watch(const DistConfig& cfg) {
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

c10::intrusive_ptr<c10d::Store> Comm::Impl::client(const DistConfig& c, bool server,
                                                   std::chrono::milliseconds timeout) const {
  c10d::TCPStoreOptions so;
  so.port = uint16_t(c.master_port);
  so.isServer = server;
  so.waitWorkers = false;
  so.timeout = timeout;
  return c10::make_intrusive<c10d::PrefixStore>(prefix, c10::make_intrusive<c10d::TCPStore>(c.master_addr, so));
}

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

}  // namespace reefgen::train
