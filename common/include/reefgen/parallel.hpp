#pragma once
// Running independent tasks on a few threads, and showing that they move.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace reefgen {

inline int default_threads() {
  const unsigned n = std::thread::hardware_concurrency();
  return n ? static_cast<int>(n) : 1;
}

// The CPU's model name (Linux /proc/cpuinfo), printed beside every timing:
// the figures depend on it and the machine changes between sessions.
inline std::string cpu_model() {
  std::FILE* f = std::fopen("/proc/cpuinfo", "r");
  if (!f) return "unknown";
  char line[512];
  std::string model = "unknown";
  while (std::fgets(line, sizeof line, f)) {
    const std::string s(line);
    if (s.rfind("model name", 0) != 0) continue;
    const size_t colon = s.find(':');
    if (colon != std::string::npos) model = s.substr(s.find_first_not_of(' ', colon + 1));
    while (!model.empty() && (model.back() == '\n' || model.back() == ' ')) model.pop_back();
    break;
  }
  std::fclose(f);
  return model;
}

// Progress on stderr unless quiet: on a terminal a line redrawn in place
// (5 times a second at most), otherwise (a log, srun, a pipe) a plain line
// every 10 s, so a long job in a batch log is seen to move. Data goes to
// stdout, so piping a command never mixes the two.
class Progress {
 public:
  Progress(std::string what, size_t total, bool quiet)
      : what_(std::move(what)), total_(total), on_(!quiet), tty_(::isatty(2) != 0), start_(clock::now()),
        last_(tty_ ? clock::time_point{} : start_) {}
  void tick(size_t done) {
    if (!on_) return;
    std::lock_guard<std::mutex> lock(m_);
    const auto now = clock::now();
    if (tty_ ? (done < total_ && now - last_ < std::chrono::milliseconds(200)) : (now - last_ < std::chrono::seconds(10)))
      return;
    last_ = now;
    const double s = std::chrono::duration<double>(now - start_).count();
    std::fprintf(stderr, "%s%s %zu/%zu (%.0f%%) %.1f/s%s", tty_ ? "\r" : "", what_.c_str(), done, total_,
                 total_ ? 100.0 * done / total_ : 100.0, s > 0 ? done / s : 0.0,
                 tty_ ? (done >= total_ ? "   \n" : "   ") : "\n");
    std::fflush(stderr);
  }

 private:
  using clock = std::chrono::steady_clock;
  std::string what_;
  size_t total_;
  bool on_, tty_;
  clock::time_point start_, last_;
  std::mutex m_;
};

// Runs task(i) for i in [0, n) on `threads` workers. The first exception stops
// the remaining work and is rethrown. Tasks must be independent: each output
// depends only on its index, never on scheduling.
inline void parallel_for(size_t n, int threads, const std::function<void(size_t)>& task,
                         const std::function<void(size_t)>& on_done = {}) {
  std::atomic<size_t> next{0}, done{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex m;
  auto worker = [&] {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= n || failed) return;
      try {
        task(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(m);
        if (!failed.exchange(true)) error = std::current_exception();
        return;
      }
      const size_t d = ++done;
      if (on_done) on_done(d);
    }
  };
  const int t = std::max(1, std::min<int>(threads, static_cast<int>(n)));
  std::vector<std::thread> pool;
  for (int k = 1; k < t; ++k) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace reefgen
