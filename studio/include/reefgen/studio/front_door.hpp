#pragma once
// The studio's front door (docs/STUDIO.md, "Slow clients"):
// it owns the public port, holds every new connection in one poll loop until
// its request head (up to the blank line) has arrived, and only then relays
// it to the HTTP library listening on loopback. A client that trickles its
// head gets at most kHeadDeadline and is answered 408, and no number of them
// occupies a worker: cpp-httplib 0.11 gives each connection a worker from
// accept and reads the head with a per-read timeout only.
#include <atomic>
#include <chrono>
#include <memory>
#include <string>

namespace reefgen::studio {

struct FrontDoorLimits {
  std::chrono::milliseconds head_deadline{10000};  // whole request head, from accept (StudioOptions)
  int max_waiting = 1024;                          // connections whose head is incomplete; oldest closed first
  int max_relays = 256;                            // connections being relayed; beyond, 503
  size_t max_head_bytes = 16384;                   // larger heads are relayed as they are (the library answers 431)
  std::chrono::milliseconds answer_wait{900000};   // from the request to the answer's first byte (a 4096² infer computes for minutes); beyond, 504
  std::chrono::milliseconds relay_idle{30000};     // once the answer has begun, both directions idle this long: closed
};

class FrontDoor {
 public:
  // Binds host:port (0 = any free port); throws reefgen::Error naming the
  // address when it cannot (in use, no such address).
  FrontDoor(const std::string& host, int port, FrontDoorLimits limits = {});
  ~FrontDoor();
  FrontDoor(const FrontDoor&) = delete;
  FrontDoor& operator=(const FrontDoor&) = delete;

  int port() const { return port_; }
  // Serves until stop(): relays complete heads to backend_port on 127.0.0.1.
  void run(int backend_port);
  void stop();  // from any thread

 private:
  int listen_fd_ = -1, wake_[2] = {-1, -1}, port_ = -1;
  FrontDoorLimits limits_;
  std::atomic<bool> stopping_{false};
  // Relays in flight; shared with their detached threads, which may outlive
  // this object by up to answer_wait.
  std::shared_ptr<std::atomic<int>> relays_ = std::make_shared<std::atomic<int>>(0);
};

}  // namespace reefgen::studio
