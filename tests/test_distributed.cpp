// LibTorch's c10d on Debian: a TCPStore and a Gloo process group per rank on
// loopback, all-reducing tensors. The data-parallel trainer (issue 21) builds
// on exactly this; the test pins down that Debian's libtorch and libgloo-dev
// (USE_C10D_GLOO) link and talk to each other.
#include <chrono>
#include <future>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#include <torch/torch.h>

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
