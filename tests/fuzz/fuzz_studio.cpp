// libFuzzer target: the studio's request handling. Any bytes are
// sent as one raw HTTP request to a real server on a loopback port: request
// line, query, headers and body, parsed by the HTTP library and then by the
// studio's checks and handlers. Findings: a crash, a sanitizer report, no
// answer, a 500 (every bad request must be a 4xx naming what is wrong), an
// error body that is not one line of JSON, or a file written outside the
// output folder. "@PORT@" in the input becomes the server's port.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "reefgen/studio/server.hpp"

namespace fs = std::filesystem;

namespace {

struct Fixture {
  fs::path dir;
  std::unique_ptr<reefgen::studio::StudioServer> server;
  std::thread thread;
  int port = 0;
  Fixture() {
    dir = fs::temp_directory_path() / ("reefgen-fuzz-studio-" + std::to_string(::getpid()));
    fs::create_directories(dir / "page");
    std::FILE* f = std::fopen((dir / "page" / "index.html").c_str(), "wb");
    std::fputs("<!doctype html><title>studio</title>", f);
    std::fclose(f);
    reefgen::studio::StudioOptions o;
    o.port = 0;
    o.model = fs::path(REEFGEN_SOURCE_DIR) / "models" / "reef-256.pt";
    o.out_dir = dir / "exports";
    o.assets_dir = dir / "page";
    o.max_body_bytes = 1 << 20;
    o.max_side = 256;  // keeps each request fast
    o.precision = "fp32";
    o.presets = {{"round", R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98]})"}};
    server = std::make_unique<reefgen::studio::StudioServer>(o);
    port = server->bind();
    thread = std::thread([this] { server->serve(); });
    thread.detach();  // lives as long as the fuzzing process
  }
};

Fixture* g_fixture = nullptr;

Fixture& fixture() {
  if (!g_fixture) {
    g_fixture = new Fixture();  // never destroyed: the server thread outlives main's statics
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(g_fixture->dir, ec);
    });
  }
  return *g_fixture;
}

// Sends the request, half-closes, reads the answer until the server closes.
std::string exchange(int port, const uint8_t* data, size_t size) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) std::abort();
  timeval tv{15, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  for (size_t sent = 0; sent < size;) {
    const ssize_t n = ::send(fd, data + sent, size - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // answered and closed before reading everything: fine
    sent += size_t(n);
  }
  ::shutdown(fd, SHUT_WR);
  std::string resp;
  char buf[8192];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) resp.append(buf, size_t(n));
  ::close(fd);
  return resp;
}

void finding(const char* what, const std::string& resp) {
  std::fprintf(stderr, "fuzz_studio: %s\n%.600s\n", what, resp.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Fixture& f = fixture();
  // The port is chosen at start; inputs write it as @PORT@ (Host, Origin),
  // so that the corpus reaches past the Host check.
  std::string req(reinterpret_cast<const char*>(data), size);
  for (size_t at = req.find("@PORT@"); at != std::string::npos; at = req.find("@PORT@", at))
    req.replace(at, 6, std::to_string(f.port));
  const std::string resp = exchange(f.port, reinterpret_cast<const uint8_t*>(req.data()), req.size());
  // Keep-alive: several requests may be answered; judge each status line.
  for (size_t at = resp.find("HTTP/1.1 "); at != std::string::npos; at = resp.find("HTTP/1.1 ", at + 9)) {
    if (at + 12 > resp.size()) break;
    const int status = std::atoi(resp.substr(at + 9, 3).c_str());
    if (status >= 500) finding("a 5xx answer", resp.substr(at));
    const size_t head_end = resp.find("\r\n\r\n", at);
    // A HEAD request's answer has a Content-Length but no body: with one in
    // the input (keep-alive may pair answers with several requests), bodies
    // are not judged.
    if (status >= 400 && head_end != std::string::npos && req.find("HEAD") == std::string::npos) {
      const size_t cl = resp.find("Content-Length: ", at);
      if (cl == std::string::npos || cl > head_end) continue;
      const size_t len = std::stoul(resp.substr(cl + 16));
      // Cut short: the server answered a refused request and closed while
      // the rest of the input was still unread, so TCP reset the connection
      // and dropped what was in flight. Not judged.
      if (head_end + 4 + len > resp.size()) continue;
      const std::string body = resp.substr(head_end + 4, len);
      const auto j = nlohmann::json::parse(body, nullptr, false);
      if (j.is_discarded() || !j.contains("error") || !j["error"].is_string())
        finding("an error without a JSON {\"error\": ...} body", resp.substr(at));
      if (j["error"].get<std::string>().find('\n') != std::string::npos) finding("a multi-line error", resp.substr(at));
    }
  }
  // Nothing but the output folder and the page may appear in the fixture's folder.
  for (const auto& e : fs::directory_iterator(f.dir))
    if (e.path().filename() != "exports" && e.path().filename() != "page")
      finding(("a file outside the output folder: " + e.path().string()).c_str(), resp);
  return 0;
}
