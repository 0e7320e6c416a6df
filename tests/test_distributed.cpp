// Data-parallel training on loopback (docs/TRAINING.md):
// - LibTorch's c10d on Debian: a TCPStore and a Gloo process group per rank,
//   all-reducing tensors (Debian's libtorch and libgloo-dev talk to each other);
// - where a rank learns who it is (torchrun, SLURM, flags) and the errors;
// - whole ranks (reefgen-torch train): 2 ranks x batch b against 1 rank x 2b,
//   resume across world sizes, a killed rank, a bad environment.
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <future>
#include <map>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <netinet/in.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#include <torch/torch.h>

#include "reefgen/train/distributed.hpp"
#include "reefgen/train/trainer.hpp"
#include "train_fixture.hpp"

namespace {

c10::intrusive_ptr<c10d::ProcessGroupGloo> make_group(const c10::intrusive_ptr<c10d::Store>& store, int rank,
                                                      int world) {
  auto opts = c10d::ProcessGroupGloo::Options::create();
  opts->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
  opts->timeout = std::chrono::seconds(30);
  return c10::make_intrusive<c10d::ProcessGroupGloo>(store, rank, world, opts);
}

c10::intrusive_ptr<c10d::TCPStore> make_store(int rank, int world, uint16_t port) {
  c10d::TCPStoreOptions so;
  so.port = port;  // 0 on rank 0: any free port, read back with getPort()
  so.isServer = rank == 0;
  so.numWorkers = world;
  so.waitWorkers = false;
  so.timeout = std::chrono::seconds(30);
  return c10::make_intrusive<c10d::TCPStore>("127.0.0.1", so);
}

}  // namespace

TEST(C10dGloo, TwoRanksOnLoopbackAllReduceAndBroadcast) {
  const int world = 2;
  auto server = make_store(0, world, 0);
  const uint16_t port = server->getPort();
  ASSERT_GT(port, 0);
  // Ranks as threads: each group has its own Gloo context and sockets.
  auto rank_body = [&](int rank) {
    const c10::intrusive_ptr<c10d::Store> store =
        rank == 0 ? c10::intrusive_ptr<c10d::Store>(server) : c10::intrusive_ptr<c10d::Store>(make_store(rank, world, port));
    auto pg = make_group(store, rank, world);
    // All-reduce (sum) of a gradient-sized tensor: every rank gets the sum.
    std::vector<at::Tensor> g = {torch::arange(100000, torch::kFloat32) * float(rank + 1)};
    pg->allreduce(g)->wait();
    // Broadcast from rank 0: rank 0's initial weights reach everyone.
    std::vector<at::Tensor> w = {torch::full({7, 5}, rank == 0 ? 3.5f : -1.0f)};
    pg->broadcast(w)->wait();
    return std::make_pair(g[0], w[0]);
  };
  auto r1 = std::async(std::launch::async, rank_body, 1);
  auto [g0, w0] = rank_body(0);
  auto [g1, w1] = r1.get();
  const at::Tensor want = torch::arange(100000, torch::kFloat32) * 3.0f;  // 1 + 2
  EXPECT_TRUE(torch::equal(g0, want));
  EXPECT_TRUE(torch::equal(g1, want));
  EXPECT_TRUE(torch::equal(w1, torch::full({7, 5}, 3.5f)));
  EXPECT_TRUE(torch::equal(w0, w1));
}

// ---------------------------------------------------------------------------
// Who am I: torchrun, SLURM, flags.

namespace {

using namespace reefgen;
using namespace reefgen::train;
using Env = std::map<std::string, std::string>;

DistConfig from(const Env& env, const DistFlags& flags = {}) {
  return dist_config_from(
      [&](const char* k) -> const char* {
        auto it = env.find(k);
        return it == env.end() ? nullptr : it->second.c_str();
      },
      flags);
}

void expect_error(const Env& env, const std::string& needle, const DistFlags& flags = {}) {
  try {
    from(env, flags);
    ADD_FAILURE() << "no error; expected one naming " << needle;
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(needle), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << "not one line: " << m;
  }
}

}  // namespace

// Every field of a DistConfig but `source`, in one line: a whole config is
// compared at once, so a field parsed wrongly or left at a stale default shows.
std::string fields(const DistConfig& c) {
  char b[256];
  std::snprintf(b, sizeof b, "rank %d of %d, local %d of %d, %s:%d, agent %d attempt %d, timeout %g", c.rank,
                c.world_size, c.local_rank, c.local_world_size, c.master_addr.c_str(), c.master_port,
                int(c.agent_store), c.restart_count, c.timeout_s);
  return b;
}

TEST(DistConfig, TorchrunSlurmAndFlags) {
  EXPECT_EQ(fields(from({})), "rank 0 of 1, local 0 of 1, 127.0.0.1:29500, agent 0 attempt 0, timeout 300");
  EXPECT_EQ(fields(from({{"RANK", "3"}, {"WORLD_SIZE", "8"}, {"LOCAL_RANK", "1"}, {"LOCAL_WORLD_SIZE", "2"},
                         {"MASTER_ADDR", "node7"}, {"MASTER_PORT", "29511"},
                         {"TORCHELASTIC_USE_AGENT_STORE", "True"}, {"TORCHELASTIC_RESTART_COUNT", "2"}})),
            "rank 3 of 8, local 1 of 2, node7:29511, agent 1 attempt 2, timeout 300");
  EXPECT_FALSE(from({{"RANK", "0"}, {"WORLD_SIZE", "2"}, {"TORCHELASTIC_USE_AGENT_STORE", "False"}}).agent_store);
  EXPECT_EQ(fields(from({{"SLURM_PROCID", "5"}, {"SLURM_NTASKS", "6"}, {"SLURM_LOCALID", "1"},
                         {"SLURM_NTASKS_PER_NODE", "2(x3)"}, {"SLURM_JOB_NODELIST", "reef[07-09],gpu1"}})),
            "rank 5 of 6, local 1 of 2, reef07:29500, agent 0 attempt 0, timeout 300");
  // torchrun's variables win over SLURM's (torchrun inside an allocation).
  EXPECT_EQ(from({{"RANK", "1"}, {"WORLD_SIZE", "2"}, {"SLURM_PROCID", "0"}, {"SLURM_NTASKS", "1"}}).world_size, 2);
  // Flags win over both.
  DistFlags f;
  f.rank = 1;
  f.world_size = 4;
  f.master_addr = "10.0.0.1";
  f.master_port = 4000;
  f.timeout_s = 12;
  EXPECT_EQ(fields(from({{"RANK", "0"}, {"WORLD_SIZE", "2"}}, f)),
            "rank 1 of 4, local 0 of 1, 10.0.0.1:4000, agent 0 attempt 0, timeout 12");
}

TEST(DistConfig, FirstSlurmHost) {
  EXPECT_EQ(first_slurm_host("node1"), "node1");
  EXPECT_EQ(first_slurm_host("node1,node2"), "node1");
  EXPECT_EQ(first_slurm_host("node[03-05,09],gpu1"), "node03");
  EXPECT_EQ(first_slurm_host("c[12,40-41]"), "c12");
  EXPECT_EQ(first_slurm_host("rack1-n[2-3]"), "rack1-n2");
}

TEST(DistConfig, BadEnvironmentIsOneLineNamingTheVariable) {
  expect_error({{"RANK", "0"}, {"WORLD_SIZE", "0"}}, "WORLD_SIZE=0");
  expect_error({{"RANK", "2"}, {"WORLD_SIZE", "2"}}, "RANK=2");
  expect_error({{"RANK", "x"}, {"WORLD_SIZE", "2"}}, "RANK=x");
  expect_error({{"RANK", "0"}}, "WORLD_SIZE");
  expect_error({{"RANK", "0"}, {"WORLD_SIZE", "2"}, {"MASTER_PORT", "70000"}}, "MASTER_PORT=70000");
  expect_error({{"SLURM_PROCID", "4"}, {"SLURM_NTASKS", "4"}, {"SLURM_JOB_NODELIST", "n1"}}, "SLURM_PROCID=4");
  expect_error({{"SLURM_PROCID", "0"}, {"SLURM_NTASKS", "2"}}, "SLURM_JOB_NODELIST");
  DistFlags f;
  f.rank = 3;
  expect_error({{"RANK", "0"}, {"WORLD_SIZE", "2"}}, "--rank=3", f);
}

// ---------------------------------------------------------------------------
// Whole ranks: reefgen-torch train as a subprocess.

namespace {

using test::make_dataset;
using test::temp_dir;
using test::tiny_params;

struct Proc {
  pid_t pid = -1;
  fs::path err;  // its stderr
};

// Starts `reefgen-torch args…` with `env` added to this environment and
// stderr to a file.
Proc spawn(const std::vector<std::string>& args, const Env& env, const fs::path& err) {
  std::vector<std::string> envs;
  for (char** e = ::environ; *e; ++e) {
    const std::string kv = *e;
    const std::string key = kv.substr(0, kv.find('='));
    if (!env.count(key) && key != "RANK" && key != "WORLD_SIZE" && key.rfind("SLURM_", 0) != 0) envs.push_back(kv);
  }
  for (const auto& [k, v] : env) envs.push_back(k + "=" + v);
  std::vector<std::string> argv_s = {REEFGEN_TORCH_BIN};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv, envp;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  for (auto& e : envs) envp.push_back(e.data());
  envp.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  Proc p;
  p.err = err;
  EXPECT_EQ(posix_spawn(&p.pid, argv[0], &fa, nullptr, argv.data(), envp.data()), 0);
  posix_spawn_file_actions_destroy(&fa);
  return p;
}

// Exit code (128 + signal when killed), or -1 after `timeout_s`.
int wait_for(const Proc& p, double timeout_s) {
  const auto t0 = std::chrono::steady_clock::now();
  for (;;) {
    int status = 0;
    if (::waitpid(p.pid, &status, WNOHANG) == p.pid)
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() > timeout_s) {
      ::kill(p.pid, SIGKILL);
      ::waitpid(p.pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// A loopback port nobody listens on: bind one, read it, close it.
std::string unused_loopback_port() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  EXPECT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(s);
  return std::to_string(ntohs(a.sin_port));
}

int run_cli(const std::vector<std::string>& args, const Env& env, const fs::path& err, double timeout_s = 120) {
  return wait_for(spawn(args, env, err), timeout_s);
}

fs::path write_config(const fs::path& dir, const TrainParams& p) {
  const fs::path f = dir / "config.json";
  write_json_atomic(f, nlohmann::json(p));
  return f;
}

// Loss columns (G_GAN, G_L1, D_real, D_fake) of every log.csv row.
std::vector<std::vector<double>> losses(const fs::path& log) {
  std::ifstream in(log);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    std::string cell;
    for (int c = 0; std::getline(ss, cell, ','); ++c)
      if (c >= 3 && c <= 6) v.push_back(std::stod(cell));
    rows.push_back(v);
  }
  return rows;
}

// Largest |a - b| / max(1, |a|) over the parameters and buffers of G and D.
double weight_gap(const fs::path& a, const fs::path& b, const TrainParams& pa, const TrainParams& pb) {
  Pix2Pix x(pix2pix_options(pa)), y(pix2pix_options(pb));
  load_checkpoint(a, x, pa, nullptr, nullptr, 1);
  load_checkpoint(b, y, pb, nullptr, nullptr, 1);
  double gap = 0;
  std::string worst;
  for (auto [m, n] : {std::pair<torch::nn::Module*, torch::nn::Module*>{x.G().get(), y.G().get()},
                      {x.D().get(), y.D().get()}}) {
    auto check = [&](const torch::OrderedDict<std::string, torch::Tensor>& ta,
                     const torch::OrderedDict<std::string, torch::Tensor>& tb) {
      for (const auto& kv : ta) {
        const torch::Tensor u = kv.value().to(torch::kFloat64), v = tb[kv.key()].to(torch::kFloat64);
        const double g = ((u - v).abs() / u.abs().clamp_min(1.0)).max().item<double>();
        if (g > gap) worst = kv.key();
        gap = std::max(gap, g);
      }
    };
    check(m->named_parameters(), n->named_parameters());
    check(m->named_buffers(), n->named_buffers());
  }
  std::printf("weights: the largest gap %.2g in %s\n", gap, worst.c_str());
  return gap;
}

double loss_gap(const fs::path& a, const fs::path& b) {
  const auto la = losses(a), lb = losses(b);
  EXPECT_EQ(la.size(), lb.size());
  double gap = 0;
  for (size_t i = 0; i < std::min(la.size(), lb.size()); ++i)
    for (size_t k = 0; k < 4; ++k) gap = std::max(gap, std::abs(la[i][k] - lb[i][k]) / std::max(1.0, std::abs(la[i][k])));
  return gap;
}

TrainParams dp_params() {
  TrainParams p = tiny_params();  // BatchNorm and dropout on, as pix2pix
  // Not 6 levels at 64 px: there the innermost levels are 1 and 2 px a side,
  // where BatchNorm over a global batch of 2 normalises so few values that
  // the gradient into them is float noise, and Adam (dividing by its own
  // running size) turns noise into steps of lr either way: two exact runs
  // parted by 2.7e-4 there, while every loss agreed within 1e-6.
  p.depth = 5;
  p.log_every = 1;
  p.checkpoint_every = 100;
  p.val_every = 100;
  return p;
}

}  // namespace

// The bar of docs/TRAINING.md: 2 ranks x batch 1 train as 1 rank x batch 2
// (synchronised BatchNorm, averaged gradients, per-sample dropout, the same
// sample order), losses and weights within 1e-4 after every step of a run.
TEST(DataParallel, TwoRanksEqualOneRankWithTheGlobalBatch) {
  const fs::path data = make_dataset("dp_equal_data", 10, 2);  // 8 train pairs: 4 steps per epoch at 2
  const fs::path base = temp_dir("dp_equal");
  TrainParams one = dp_params();
  one.batch_size = 2;
  one.threads = 2;
  RunOptions r;
  r.data = data;
  r.out = base / "one";
  EXPECT_EQ(run_training(one, r).step, 8);

  TrainParams two = dp_params();
  two.batch_size = 1;
  two.threads = 1;
  const fs::path cfg = write_config(base, two);
  ASSERT_EQ(run_cli({"train", "--config", cfg.string(), "--data", data.string(), "--out", (base / "two").string(),
                     "--nproc", "2", "--dist-timeout", "60", "--bucket-mb", "0.002"},  // 500 floats: many buckets
                    {}, base / "two.err"),
            0)
      << read_text(base / "two.err");
  EXPECT_EQ(losses(base / "two" / "log.csv").size(), 8u);
  const double lg = loss_gap(base / "one" / "log.csv", base / "two" / "log.csv");
  const double wg = weight_gap(base / "one" / "checkpoint.pt", base / "two" / "checkpoint.pt", one, one);
  std::printf("2 ranks x 1 vs 1 rank x 2, 8 steps: losses within %.2g, weights within %.2g\n", lg, wg);
  EXPECT_LT(lg, 1e-4);
  EXPECT_LT(wg, 1e-4);
  // Only rank 0 wrote: one run folder, its files once.
  EXPECT_TRUE(fs::exists(base / "two" / "generator.pt"));
  const nlohmann::json run = read_json(base / "two" / "run.json");
  EXPECT_EQ(run.at("world_size"), 2);
  EXPECT_EQ(run.at("global_batch"), 2);

  // Without synchronised BatchNorm the ranks would not be one run: the
  // check above can fail. One rank x batch 1 on the same first samples
  // differs by far more than the tolerance.
  TrainParams solo = dp_params();
  solo.batch_size = 1;
  RunOptions rs;
  rs.data = data;
  rs.out = base / "solo";
  rs.max_steps = 8;
  run_training(solo, rs);
  EXPECT_GT(loss_gap(base / "one" / "log.csv", base / "solo" / "log.csv"), 1e-3);
  fs::remove_all(base);
  fs::remove_all(data);
}

TEST(DataParallel, ResumeAcrossWorldSizes) {
  const fs::path data = make_dataset("dp_resume_data", 10, 2);
  const fs::path base = temp_dir("dp_resume");
  TrainParams one = dp_params();
  one.batch_size = 2;
  RunOptions full;
  full.data = data;
  full.out = base / "full";
  run_training(one, full);

  // 2 ranks stop at step 3 (--max-steps), then 1 rank x 2 finishes the run.
  TrainParams two = dp_params();
  two.batch_size = 1;
  two.threads = 1;
  const fs::path cfg = write_config(base, two);
  ASSERT_EQ(run_cli({"train", "--config", cfg.string(), "--data", data.string(), "--out", (base / "part").string(),
                     "--nproc", "2", "--max-steps", "3"},
                    {}, base / "part.err"),
            0)
      << read_text(base / "part.err");
  // Another global batch is refused, naming the fix.
  RunOptions part;
  part.data = data;
  part.out = base / "part";
  part.resume = true;
  try {
    run_training(two, part);
    ADD_FAILURE() << "a resume with another global batch was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("global batch of 2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(run_training(one, part).step, 8);
  EXPECT_LT(loss_gap(base / "full" / "log.csv", base / "part" / "log.csv"), 1e-4);
  EXPECT_LT(weight_gap(base / "full" / "checkpoint.pt", base / "part" / "checkpoint.pt", one, one), 1e-4);

  // And the other way: 1 rank x 2 to step 3, 2 ranks x 1 to the end.
  RunOptions back;
  back.data = data;
  back.out = base / "back";
  back.max_steps = 3;
  run_training(one, back);
  ASSERT_EQ(run_cli({"train", "--config", cfg.string(), "--data", data.string(), "--out", (base / "back").string(),
                     "--nproc", "2", "--resume"},
                    {}, base / "back.err"),
            0)
      << read_text(base / "back.err");
  EXPECT_LT(loss_gap(base / "full" / "log.csv", base / "back" / "log.csv"), 1e-4);
  EXPECT_LT(weight_gap(base / "full" / "checkpoint.pt", base / "back" / "checkpoint.pt", one, one), 1e-4);
  fs::remove_all(base);
  fs::remove_all(data);
}

// A 2-rank job far longer than any test (--nproc 2, a checkpoint per step),
// returned once training is under way: the launcher has named rank 1's pid
// and rank 0 has written a checkpoint.
struct LongJob {
  fs::path data, base;
  TrainParams params;
  std::vector<std::string> args;
  Proc job;
  pid_t rank0 = -1, rank1 = -1;
};
LongJob start_long_job(const std::string& name, const std::vector<std::string>& extra) {
  LongJob j;
  j.data = make_dataset(name + "_data", 10, 2);
  j.base = temp_dir(name);
  j.params = dp_params();
  j.params.batch_size = 1;
  j.params.threads = 1;
  j.params.epochs = 1000;
  j.params.checkpoint_every = 1;
  const fs::path cfg = write_config(j.base, j.params);
  j.args = {"train", "--config", cfg.string(), "--data", j.data.string(), "--out", (j.base / "run").string(), "--nproc", "2"};
  std::vector<std::string> all = j.args;
  all.insert(all.end(), extra.begin(), extra.end());
  j.job = spawn(all, {}, j.base / "job.err");
  for (int i = 0; i < 600 && (j.rank1 < 0 || !fs::exists(j.base / "run" / "checkpoint.pt")); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const std::string err = read_text(j.base / "job.err");
    const size_t at = err.find("rank 1: pid ");
    if (at != std::string::npos) j.rank1 = pid_t(std::stol(err.substr(at + 12)));
    const size_t at0 = err.find("rank 0: pid ");
    if (at0 != std::string::npos) j.rank0 = pid_t(std::stol(err.substr(at0 + 12)));
  }
  return j;
}

// kill -9 of one rank mid-run: the job ends within the timeout, non-zero,
// with the launcher and the surviving rank both naming the dead one.
TEST(DataParallel, KilledRankFailsTheJobNamingIt) {
  const LongJob j = start_long_job("dp_kill", {"--dist-timeout", "20"});
  const Proc& job = j.job;
  const pid_t rank1 = j.rank1;
  ASSERT_GT(rank1, 0) << read_text(j.base / "job.err");
  ASSERT_TRUE(fs::exists(j.base / "run" / "checkpoint.pt")) << read_text(j.base / "job.err");
  const auto t0 = std::chrono::steady_clock::now();
  ::kill(rank1, SIGKILL);
  const int code = wait_for(job, 60);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::string err = read_text(j.base / "job.err");
  EXPECT_NE(code, 0) << err;
  EXPECT_NE(code, -1) << "the job hung after a rank was killed: " << err;
  EXPECT_LT(took, 30) << err;
  EXPECT_NE(err.find("rank 1 was killed by signal 9"), std::string::npos) << err;
  EXPECT_NE(err.find("rank 0: rank 1 stopped answering"), std::string::npos) << err;
  // The last checkpoint is whole: the run can be resumed.
  Pix2Pix q(pix2pix_options(j.params));
  EXPECT_GE(load_checkpoint(j.base / "run" / "checkpoint.pt", q, j.params, nullptr, nullptr, 2), 1);
  fs::remove_all(j.base);
  fs::remove_all(j.data);
}

// A bad environment: one line naming the variable, non-zero, nothing written.
TEST(DataParallel, BadEnvironmentWritesNothing) {
  const fs::path data = make_dataset("dp_env_data", 4, 1);
  const fs::path base = temp_dir("dp_env");
  const std::string closed_port = unused_loopback_port();
  const std::vector<std::pair<Env, std::string>> cases = {
      {{{"RANK", "0"}, {"WORLD_SIZE", "0"}}, "WORLD_SIZE=0"},
      {{{"RANK", "2"}, {"WORLD_SIZE", "2"}}, "RANK=2"},
      {{{"RANK", "1"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "127.0.0.1"}, {"MASTER_PORT", closed_port}},
       "cannot reach the rendezvous store at 127.0.0.1:" + closed_port},
  };
  int i = 0;
  for (const auto& [env, needle] : cases) {
    const fs::path out = base / ("run" + std::to_string(i++));
    const int code = run_cli({"train", "--data", data.string(), "--out", out.string(), "--dist-timeout", "2"}, env,
                             base / "err.txt", 60);
    const std::string err = read_text(base / "err.txt");
    EXPECT_NE(code, 0) << needle;
    EXPECT_NE(err.find(needle), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "not one line: " << err;
    EXPECT_FALSE(fs::exists(out)) << needle << ": the run folder was created";
  }
  fs::remove_all(base);
  fs::remove_all(data);
}

// Ctrl-C (SIGINT to the launcher): every rank stops after the same step,
// rank 0 writes the checkpoint, the job exits with 130 and resumes.
TEST(DataParallel, InterruptStopsEveryRankAfterTheSameStepAndResumes) {
  const LongJob j = start_long_job("dp_int", {});
  const Proc& job = j.job;
  const fs::path& base = j.base;
  const TrainParams& p = j.params;
  ASSERT_TRUE(fs::exists(base / "run" / "checkpoint.pt")) << read_text(base / "job.err");
  ::kill(job.pid, SIGINT);
  EXPECT_EQ(wait_for(job, 60), 130) << read_text(base / "job.err");
  Pix2Pix q(pix2pix_options(p));
  const int64_t step = load_checkpoint(base / "run" / "checkpoint.pt", q, p, nullptr, nullptr, 2);
  EXPECT_GE(step, 1);
  // log.csv ends at the checkpoint's step (nothing after it, nothing lost).
  const auto rows = losses(base / "run" / "log.csv");
  EXPECT_EQ(int64_t(rows.size()), step);
  // --resume continues from there (stopped again by --max-steps).
  std::vector<std::string> more = j.args;
  more.insert(more.end(), {"--resume", "--max-steps", std::to_string(step + 2)});
  ASSERT_EQ(run_cli(more, {}, base / "resume.err"), 0) << read_text(base / "resume.err");
  EXPECT_EQ(int64_t(losses(base / "run" / "log.csv").size()), step + 2);
  fs::remove_all(base);
  fs::remove_all(j.data);
}

// A hung rank (SIGSTOP: alive, silent): the survivor's collective times out
// after --dist-timeout and it names the silent rank; the launcher stops the
// job (SIGKILL after its grace period) instead of waiting forever.
TEST(DataParallel, HungRankTimesOutNamingIt) {
  const LongJob j = start_long_job("dp_hang", {"--dist-timeout", "4"});
  const pid_t rank1 = j.rank1;
  ASSERT_GT(rank1, 0) << read_text(j.base / "job.err");
  ASSERT_TRUE(fs::exists(j.base / "run" / "checkpoint.pt")) << read_text(j.base / "job.err");
  ::kill(rank1, SIGSTOP);
  const int code = wait_for(j.job, 90);
  const std::string err = read_text(j.base / "job.err");
  ::kill(rank1, SIGKILL);  // in case the launcher did not
  EXPECT_NE(code, 0) << err;
  EXPECT_NE(code, -1) << "the job hung: " << err;
  EXPECT_NE(err.find("rank 0: rank 1 stopped answering"), std::string::npos) << err;
  fs::remove_all(j.base);
  fs::remove_all(j.data);
}

namespace {
// A TCP listener on a free loopback port that answers every connection with
// `greeting` (nothing when empty) and keeps it open: a foreign service.
struct ForeignService {
  int fd = -1;
  uint16_t port = 0;
  std::thread th;
  std::atomic<bool> stop{false};
  explicit ForeignService(std::string greeting) {
    fd = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t len = sizeof a;
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    EXPECT_EQ(::listen(fd, 8), 0);
    th = std::thread([this, greeting] {
      std::vector<int> open;
      while (!stop) {
        const int c = ::accept(fd, nullptr, nullptr);
        if (c < 0) {
          std::this_thread::sleep_for(std::chrono::milliseconds(20));
          continue;
        }
        if (!greeting.empty()) (void)!::send(c, greeting.data(), greeting.size(), MSG_NOSIGNAL);
        open.push_back(c);
      }
      for (int c : open) ::close(c);
    });
  }
  ~ForeignService() {
    stop = true;
    th.join();
    ::close(fd);
  }
};

bool process_gone(pid_t pid) {
  if (::kill(pid, 0) != 0) return true;
  // Re-parented to an init that has not reaped it yet: a zombie is gone too.
  std::ifstream st("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_s, comm, state;
  st >> pid_s >> comm >> state;
  return !st || state == "Z";
}
}  // namespace

// MASTER_PORT reaching a service that is not a rendezvous store
// (silent like an HTTP server waiting for a request, an SSH banner, random
// bytes) is one line naming it, not an abort (status 134) from LibTorch's
// client trusting the bytes it reads.
TEST(DataParallel, ForeignServiceOnTheMasterPortIsOneLine) {
  const fs::path data = make_dataset("dp_foreign_data", 4, 1);
  const fs::path base = temp_dir("dp_foreign");
  std::string noise(4096, '\0');
  uint32_t x = 12345;
  for (char& c : noise) c = char((x = x * 1664525u + 1013904223u) >> 24);
  const std::vector<std::pair<std::string, std::string>> services = {
      {"", "no answer within"}, {"SSH-2.0-OpenSSH_9.2p1 Debian-2\r\n", "SSH-2.0-"}, {noise, "it answered"},
      {"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n", "HTTP/1.1"}};
  for (const auto& [greeting, needle] : services) {
    ForeignService svc(greeting);
    const fs::path out = base / "run";
    const auto t0 = std::chrono::steady_clock::now();
    const int code = run_cli({"train", "--data", data.string(), "--out", out.string(), "--dist-timeout", "300"},
                             {{"RANK", "1"}, {"WORLD_SIZE", "2"}, {"MASTER_ADDR", "127.0.0.1"},
                              {"MASTER_PORT", std::to_string(svc.port)}},
                             base / "err.txt", 60);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::string err = read_text(base / "err.txt");
    EXPECT_EQ(code, 1) << err;
    EXPECT_LT(took, 30) << err;
    EXPECT_NE(err.find("is another service, not a rendezvous store"), std::string::npos) << err;
    EXPECT_NE(err.find(needle), std::string::npos) << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << "not one line: " << err;
    EXPECT_FALSE(fs::exists(out));
  }
  fs::remove_all(base);
  fs::remove_all(data);
}

// A stopped rank (SIGSTOP) ends the job within 60 s even when
// --dist-timeout lets collectives wait 300 s: the heartbeat watchdog.
TEST(DataParallel, StoppedRankEndsTheJobWithinTheLivenessDeadline) {
  const LongJob j = start_long_job("dp_stop", {"--dist-timeout", "300"});
  ASSERT_GT(j.rank1, 0) << read_text(j.base / "job.err");
  ASSERT_TRUE(fs::exists(j.base / "run" / "checkpoint.pt")) << read_text(j.base / "job.err");
  const auto t0 = std::chrono::steady_clock::now();
  ::kill(j.rank1, SIGSTOP);
  const int code = wait_for(j.job, 90);
  const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ::kill(j.rank1, SIGKILL);
  const std::string err = read_text(j.base / "job.err");
  EXPECT_NE(code, 0) << err;
  EXPECT_NE(code, -1) << "the job hung: " << err;
  EXPECT_LT(took, 60) << err;
  EXPECT_NE(err.find("rank 0: rank 1 sent no heartbeat"), std::string::npos) << err;
  fs::remove_all(j.base);
  fs::remove_all(j.data);
}

// kill -9 of the --nproc launcher leaves no rank training as an
// orphan (parent-death signal): each checkpoints and exits.
TEST(DataParallel, KilledLauncherLeavesNoOrphanRanks) {
  const LongJob j = start_long_job("dp_orphan", {});
  ASSERT_GT(j.rank0, 0) << read_text(j.base / "job.err");
  ASSERT_GT(j.rank1, 0) << read_text(j.base / "job.err");
  ::kill(j.job.pid, SIGKILL);
  int status = 0;
  ::waitpid(j.job.pid, &status, 0);
  bool gone = false;
  for (int i = 0; i < 300 && !gone; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    gone = process_gone(j.rank0) && process_gone(j.rank1);
  }
  EXPECT_TRUE(gone) << "ranks still running 30 s after their launcher died";
  if (!gone) ::kill(j.rank0, SIGKILL), ::kill(j.rank1, SIGKILL);
  // They stopped as on Ctrl-C: the checkpoint is whole.
  Pix2Pix q(pix2pix_options(j.params));
  EXPECT_GE(load_checkpoint(j.base / "run" / "checkpoint.pt", q, j.params, nullptr, nullptr, 2), 1);
  fs::remove_all(j.base);
  fs::remove_all(j.data);
}

// `train --nproc 2 --master-port P` hosts its store on P (it used
// to listen elsewhere while the ranks waited on P for --dist-timeout).
TEST(DataParallel, NprocHonoursMasterPort) {
  const fs::path data = make_dataset("dp_port_data", 4, 1);
  const fs::path base = temp_dir("dp_port");
  const std::string port = unused_loopback_port();
  TrainParams p = dp_params();
  p.batch_size = 1;
  p.threads = 1;
  const fs::path cfg = write_config(base, p);
  const auto t0 = std::chrono::steady_clock::now();
  const int code = run_cli({"train", "--config", cfg.string(), "--data", data.string(), "--out", (base / "run").string(),
                            "--nproc", "2", "--master-port", port, "--max-steps", "2", "--dist-timeout", "300"},
                           {}, base / "err.txt", 120);
  EXPECT_EQ(code, 0) << read_text(base / "err.txt");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 60);
  EXPECT_TRUE(fs::exists(base / "run" / "generator.pt"));
  fs::remove_all(base);
  fs::remove_all(data);
}
