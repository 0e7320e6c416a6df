// The rendezvous store's probe: one GETNUMKEYS query over a raw socket before
// LibTorch's own client (which trusts what it reads) is let near a port.
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <netdb.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <glog/logging.h>
#include <torch/version.h>

#include "dist_internal.hpp"

namespace reefgen::train::detail {

// c10d and Gloo report through glog (socket time-outs, retries) on stderr;
// every such failure reaches the user as one line from us instead.
void quiet_c10d_logging() { FLAGS_minloglevel = google::GLOG_FATAL; }

namespace {

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

}  // namespace

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

}  // namespace reefgen::train::detail
