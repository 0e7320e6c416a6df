#include "reefgen/studio/front_door.hpp"

#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <system_error>
#include <thread>
#include <vector>

#include "reefgen/error.hpp"

namespace reefgen::studio {

namespace {

using Clock = std::chrono::steady_clock;

// Out of file descriptors with no reserve left to answer with: the listening
// socket stays readable, so it is left out of the poll this long rather than
// spinning on accept's EMFILE.
constexpr int kNoDescriptorPauseMs = 100;
constexpr const char* kNoDescriptors = "the studio is out of file descriptors; retry shortly";

bool out_of_descriptors(int err) { return err == EMFILE || err == ENFILE; }

// Best effort: the client may be gone or not reading.
void answer_and_close(int fd, int status, const char* reason, const std::string& why) {
  const std::string body = "{\"error\":\"" + why + "\"}";
  const std::string msg = "HTTP/1.1 " + std::to_string(status) + " " + reason +
                          "\r\nContent-Type: application/json\r\nConnection: close\r\nContent-Length: " +
                          std::to_string(body.size()) + "\r\n\r\n" + body;
  [[maybe_unused]] const ssize_t n = ::send(fd, msg.data(), msg.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
  ::close(fd);
}

// Out of descriptors, with one held in `reserve` (/dev/null): frees it to
// accept the next client, answers that client 503 and takes the reserve
// back. false when no client was waiting.
bool turn_away_one(int listen_fd, int& reserve) {
  ::close(reserve);
  const int fd = ::accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
  if (fd >= 0) answer_and_close(fd, 503, "Service Unavailable", kNoDescriptors);
  reserve = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  return fd >= 0;
}

bool send_all(int fd, const char* p, size_t n) {
  while (n > 0) {
    const ssize_t w = ::send(fd, p, n, MSG_NOSIGNAL);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w, n -= size_t(w);
  }
  return true;
}

// Copies bytes both ways until the backend has answered and closed (it
// serves one request per connection), either side fails, or both idle.
// Until the answer's first byte the backend may be computing (an infer of
// minutes): the relay waits `answer_wait` for it, then answers 504 itself;
// the idle limit applies once the answer has begun (a 30 s limit from the
// start dropped every answer slower than that, its files written anyway).
void relay(int client, int backend, const FrontDoorLimits& limits) {
  pollfd fds[2] = {{client, POLLIN, 0}, {backend, POLLIN, 0}};
  char buf[65536];
  bool client_open = true, answering = false;
  const Clock::time_point answer_deadline = Clock::now() + limits.answer_wait;
  for (;;) {
    fds[0].events = client_open ? POLLIN : 0;
    const auto wait = answering ? limits.relay_idle
                                : std::chrono::duration_cast<std::chrono::milliseconds>(answer_deadline - Clock::now());
    const int r = ::poll(fds, 2, int(std::clamp<int64_t>(wait.count(), 0, INT32_MAX)));
    if (r < 0 && errno == EINTR) continue;
    if (r == 0 && !answering) {
      answer_and_close(client, 504, "Gateway Timeout",
                       "no answer within " + std::to_string(limits.answer_wait.count() / 1000) +
                           " s; ask for a smaller size (--max-side) or run the command line");
      ::close(backend);
      return;
    }
    if (r <= 0) break;
    if (fds[1].revents) {
      const ssize_t n = ::recv(backend, buf, sizeof buf, 0);
      if (n <= 0 || !send_all(client, buf, size_t(n))) break;
      answering = true;
    }
    if (client_open && fds[0].revents) {
      const ssize_t n = ::recv(client, buf, sizeof buf, 0);
      if (n < 0) break;
      // The client is done, or the backend stopped reading (it refused the
      // request, e.g. 411, and closed): its answer may still be on the way.
      if (n == 0 || !send_all(backend, buf, size_t(n))) {
        client_open = false;
        ::shutdown(backend, SHUT_WR);
      }
    }
  }
  ::close(client);
  ::close(backend);
}

int connect_loopback(int port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The head ends at the first blank line (RFC 9112 §2.1).
bool head_complete(const char* p, size_t n) { return n >= 4 && memmem(p, n, "\r\n\r\n", 4) != nullptr; }

}  // namespace

FrontDoor::FrontDoor(const std::string& host, int port, FrontDoorLimits limits) : limits_(limits) {
  const std::string where = host + ":" + std::to_string(port);
  addrinfo hints{}, *res = nullptr;
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE | AI_NUMERICSERV;
  if (::getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &res) != 0 || !res)
    throw Error("studio: cannot listen on " + where + " (no such address; use --host 127.0.0.1)");
  std::unique_ptr<addrinfo, void (*)(addrinfo*)> guard(res, ::freeaddrinfo);
  listen_fd_ = ::socket(res->ai_family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  // One listener per port: SO_REUSEADDR for TIME_WAIT, never SO_REUSEPORT
  // (a second studio would share the requests).
  int yes = 1;
  if (listen_fd_ >= 0) ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  if (listen_fd_ < 0 || ::bind(listen_fd_, res->ai_addr, res->ai_addrlen) != 0 || ::listen(listen_fd_, 1024) != 0) {
    if (listen_fd_ >= 0) ::close(listen_fd_);
    throw Error("studio: cannot listen on " + where + " (in use? choose another with --port)");
  }
  sockaddr_storage a{};
  socklen_t len = sizeof a;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&a)->sin6_port
                                         : reinterpret_cast<sockaddr_in*>(&a)->sin_port);
  if (::pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    ::close(listen_fd_);
    throw Error("studio: cannot create a pipe: " + std::string(std::strerror(errno)));
  }
}

FrontDoor::~FrontDoor() {
  for (const int fd : {listen_fd_, wake_[0], wake_[1]})
    if (fd >= 0) ::close(fd);
}

void FrontDoor::stop() {
  stopping_ = true;
  const char c = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_[1], &c, 1);
}

namespace {

struct Waiting {
  int fd;
  Clock::time_point deadline;
};

}  // namespace

// Long: one poll loop (accept, read heads, relay, time out) over the
// connection table, its only state; each branch is marked.
void FrontDoor::run(int backend_port) {
  std::vector<Waiting> waiting;  // accept order, so deadline order
  std::vector<pollfd> fds;
  std::vector<char> peek(limits_.max_head_bytes);
  const std::string late = "request head not received within " +
                           std::to_string(limits_.head_deadline.count()) + " ms; send the whole request at once";
  // What recv peeked (n > 0 bytes) is a whole head, or too long to wait for.
  auto head_ready = [&](ssize_t n) { return head_complete(peek.data(), size_t(n)) || size_t(n) == peek.size(); };
  auto hand_off = [&](int fd) {
    if (*relays_ >= limits_.max_relays) return answer_and_close(fd, 503, "Service Unavailable", "too many connections; retry");
    const int backend = connect_loopback(backend_port);
    if (backend < 0 && out_of_descriptors(errno)) return answer_and_close(fd, 503, "Service Unavailable", kNoDescriptors);
    if (backend < 0) return answer_and_close(fd, 502, "Bad Gateway", "studio backend not answering");
    ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    // A client that does not read its answer cannot hold the relay forever.
    const timeval send_timeout{10, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &send_timeout, sizeof send_timeout);
    ++*relays_;
    try {
      std::thread([fd, backend, count = relays_, limits = limits_] {
        relay(fd, backend, limits);
        --*count;
      }).detach();
    } catch (const std::system_error&) {
      // No thread to be had (process or memory limits): refuse this one.
      --*relays_;
      ::close(backend);
      answer_and_close(fd, 503, "Service Unavailable", "the studio cannot start another connection now; retry shortly");
    }
  };
  // One descriptor held in reserve: when accept fails for want of
  // descriptors it is freed to take the connection and answer it 503, so
  // clients hear why instead of waiting in the backlog.
  int reserve = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  Clock::time_point paused_until{};  // listening socket left out of the poll until then
  while (!stopping_) {
    // Taken back as soon as a descriptor is free again.
    if (reserve < 0) reserve = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
    const bool paused = Clock::now() < paused_until;
    fds.assign({{listen_fd_, short(paused ? 0 : POLLIN), 0}, {wake_[0], POLLIN, 0}});
    for (const Waiting& w : waiting) fds.push_back({w.fd, POLLIN | POLLRDHUP, 0});
    int timeout_ms = -1;
    if (!waiting.empty())
      timeout_ms = int(std::max<int64_t>(0, std::chrono::duration_cast<std::chrono::milliseconds>(
                                                waiting.front().deadline - Clock::now()).count() + 1));
    if (paused) {
      const int pause_left = int(std::chrono::duration_cast<std::chrono::milliseconds>(paused_until - Clock::now()).count() + 1);
      timeout_ms = timeout_ms < 0 ? pause_left : std::min(timeout_ms, pause_left);
    }
    if (::poll(fds.data(), fds.size(), timeout_ms) < 0 && errno != EINTR)
      throw Error("studio: poll failed: " + std::string(std::strerror(errno)));
    if (fds[1].revents || stopping_) break;
    // Heads: complete ones go to the library, closed ones are dropped.
    for (size_t k = 0; k < waiting.size(); ++k) {
      if (!fds[k + 2].revents) continue;
      int& fd = waiting[k].fd;
      const ssize_t n = ::recv(fd, peek.data(), peek.size(), MSG_PEEK);
      if (n < 0 && (errno == EAGAIN || errno == EINTR)) continue;
      if (n <= 0) {
        ::close(fd);
      } else if (head_ready(n) || (fds[k + 2].revents & POLLRDHUP)) {
        // Complete, too long to wait for, or never to be completed (the
        // client has half-closed): the library answers, as it would have.
        hand_off(fd);
      } else {
        continue;
      }
      fd = -1;
    }
    // Heads past their deadline: 408, unless the head has arrived since the
    // poll (this loop may have been held up handing heads off).
    const auto now = Clock::now();
    for (Waiting& w : waiting) {
      if (w.fd < 0 || w.deadline > now) continue;
      const ssize_t n = ::recv(w.fd, peek.data(), peek.size(), MSG_PEEK);
      if (n > 0 && head_ready(n)) hand_off(w.fd);
      else answer_and_close(w.fd, 408, "Request Timeout", late);
      w.fd = -1;
    }
    waiting.erase(std::remove_if(waiting.begin(), waiting.end(), [](const Waiting& w) { return w.fd < 0; }),
                  waiting.end());
    // New connections; past max_waiting the oldest waiting one is closed.
    if (fds[0].revents)
      for (;;) {
        const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0 && out_of_descriptors(errno)) {
          if (reserve >= 0 && turn_away_one(listen_fd_, reserve)) continue;
          if (reserve < 0) paused_until = Clock::now() + std::chrono::milliseconds(kNoDescriptorPauseMs);
          break;
        }
        if (fd < 0) break;
        const int one = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        waiting.push_back({fd, now + limits_.head_deadline});
        if (int(waiting.size()) > limits_.max_waiting) {
          answer_and_close(waiting.front().fd, 408, "Request Timeout", late);
          waiting.erase(waiting.begin());
        }
      }
  }
  for (const Waiting& w : waiting) ::close(w.fd);
  if (reserve >= 0) ::close(reserve);
}

}  // namespace reefgen::studio
