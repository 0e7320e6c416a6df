// reefgen studio's HTTP API: a real server on a free loopback port,
// a real client. The answers equal the CLI's code paths; bad requests get a
// 4xx with one line; nothing is written outside the output folder.
#include <arpa/inet.h>
#include <httplib.h>
#include <netinet/in.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <thread>

#include <zlib.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/infer/infer.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/studio/front_door.hpp"
#include "reefgen/studio/server.hpp"
#include "reefgen/studio/zip.hpp"
#include "reefgen/terrain/ocean_floor.hpp"
#include "test_util.hpp"

using namespace reefgen;
using json = nlohmann::json;
namespace fs = std::filesystem;

namespace {

const fs::path kRoot = REEFGEN_SOURCE_DIR;
// The fixture's request-head deadline (the studio's default is 10 s).
constexpr int kHeadDeadlineMs = 2000;

// A raw loopback connection that has sent `bytes` and nothing more.
int open_partial(int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  if (::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) != ssize_t(bytes.size())) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// What the server sends on fd within timeout_ms (until it closes).
std::string read_for(int fd, int timeout_ms) {
  std::string got;
  char buf[4096];
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(end - std::chrono::steady_clock::now());
    pollfd p{fd, POLLIN, 0};
    if (left.count() <= 0 || ::poll(&p, 1, int(left.count())) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.append(buf, size_t(n));
  }
  return got;
}

struct Heights {
  json meta;
  cv::Mat1f h;
};
Heights parse_heights(const std::string& body) {
  EXPECT_GE(body.size(), 4u);
  uint32_t n = 0;
  for (int i = 0; i < 4; ++i) n |= uint32_t(uint8_t(body[size_t(i)])) << (8 * i);
  EXPECT_EQ((4 + n) % 4, 0u) << "floats must start 4-byte aligned";
  Heights r;
  r.meta = json::parse(body.substr(4, n));
  const int s = r.meta.at("size");
  EXPECT_EQ(body.size(), 4 + n + size_t(s) * size_t(s) * 4);
  r.h = cv::Mat1f(s, s);
  std::memcpy(r.h.ptr<float>(), body.data() + 4 + n, size_t(s) * size_t(s) * 4);
  return r;
}

std::string file_bytes(const fs::path& p) { return read_text(p); }

class Studio : public ::testing::Test {
 protected:
  void SetUp() override {
    out = test::temp_dir("studio");
    studio::StudioOptions o;
    o.port = 0;
    o.model = kRoot / "models" / "reef-256.pt";
    o.out_dir = out / "exports";
    o.assets_dir = REEFGEN_STUDIO_ASSETS;
    o.max_body_bytes = 1 << 20;
    o.precision = "fp32";
    o.head_deadline_ms = kHeadDeadlineMs;
    o.presets = {{"round", R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98]})"}};
    server = std::make_unique<studio::StudioServer>(o);
    port = server->bind();
    thread = std::thread([this] { server->serve(); });
    client = std::make_unique<httplib::Client>("127.0.0.1", port);
    client->set_read_timeout(60, 0);
    for (int i = 0; i < 100 && !client->Get("/api/info"); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  void TearDown() override {
    server->stop();
    thread.join();
    fs::remove_all(out);
  }
  static void expect_error(const httplib::Result& r, int status, const std::string& needle) {
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, status) << r->body;
    const json j = json::parse(r->body, nullptr, false);
    ASSERT_TRUE(j.is_object() && j.contains("error")) << r->body;
    const std::string msg = j["error"];
    EXPECT_NE(msg.find(needle), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
  }
  // The painted example's heights from the studio for `query` (empty on a
  // failed request, which is reported) and from the CLI's code for `io`.
  std::pair<cv::Mat1f, cv::Mat1f> studio_and_cli(const std::string& query, const infer::InferOptions& io) {
    const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
    auto r = client->Post("/api/infer?" + query, file_bytes(sketch), "image/png");
    EXPECT_TRUE(r && r->status == 200) << (r ? r->body : "no answer");
    model::GeneratorFile g = model::load_generator(kRoot / "models" / "reef-256.pt");
    const cv::Mat1f cli = infer::infer_heights(g, {read_sketch(sketch)}, io)[0];
    return {r && r->status == 200 ? parse_heights(r->body).h : cv::Mat1f(), cli};
  }
  // Each of `bads` as ?param= is a 400 whose one line contains `needle`.
  void expect_refused(const std::string& param, const std::vector<std::string>& bads, const std::string& needle) {
    const std::string png = file_bytes(kRoot / "docs" / "examples" / "painted-sketch.png");
    for (const std::string& bad : bads) {
      SCOPED_TRACE(param + "=" + bad);
      expect_error(client->Post("/api/infer?" + param + "=" + bad, png, "image/png"), 400, needle);
    }
  }
  fs::path out;
  std::unique_ptr<studio::StudioServer> server;
  std::thread thread;
  std::unique_ptr<httplib::Client> client;
  int port = 0;
};

}  // namespace

// A backend that answers every connection `delay_ms` after its head
// (never, when delay_ms < 0): the studio's library computing an infer.
struct SlowBackend {
  int listen_fd = -1, port = -1;
  std::thread t;
  explicit SlowBackend(int delay_ms) {
    listen_fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(listen_fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    ::listen(listen_fd, 8);
    socklen_t len = sizeof a;
    ::getsockname(listen_fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
    t = std::thread([this, delay_ms] {
      const int fd = ::accept(listen_fd, nullptr, nullptr);
      if (fd < 0) return;
      char buf[4096];
      [[maybe_unused]] const ssize_t got = ::recv(fd, buf, sizeof buf, 0);
      if (delay_ms >= 0) {
        std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
        const std::string ok = "HTTP/1.1 200 OK\r\nContent-Length: 4\r\nConnection: close\r\n\r\ndone";
        [[maybe_unused]] const ssize_t sent = ::send(fd, ok.data(), ok.size(), MSG_NOSIGNAL);
      } else {
        read_for(fd, 3000);  // holds the connection, answers nothing
      }
      ::close(fd);
    });
  }
  ~SlowBackend() {
    ::shutdown(listen_fd, SHUT_RDWR);
    t.join();
    ::close(listen_fd);
  }
};

// The front door relays a slow answer whole: the idle limit applies once
// the answer has begun, not from the request (a 30 s limit from the request
// came back as an empty reply to every 4096² infer); past answer_wait the
// client hears 504 with a JSON line naming the wait.
TEST(FrontDoor, WaitsForASlowAnswerThenTimesOutWithA504) {
  for (const bool answers : {true, false}) {
    SlowBackend backend(answers ? 800 : -1);
    studio::FrontDoorLimits limits;
    limits.relay_idle = std::chrono::milliseconds(200);
    limits.answer_wait = std::chrono::milliseconds(answers ? 10000 : 600);
    studio::FrontDoor door("127.0.0.1", 0, limits);
    std::thread loop([&] { door.run(backend.port); });
    const int fd = open_partial(door.port(), "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n");
    ASSERT_GE(fd, 0);
    const std::string got = read_for(fd, 5000);
    ::close(fd);
    door.stop();
    loop.join();
    if (answers) {
      EXPECT_NE(got.find("200 OK"), std::string::npos) << got;
      EXPECT_NE(got.find("done"), std::string::npos) << got;
    } else {
      EXPECT_NE(got.find("504"), std::string::npos) << got;
      EXPECT_NE(got.find("no answer within"), std::string::npos) << got;
    }
  }
}

TEST(Base64, RoundTripAndRefusal) {
  for (const std::string& s : std::vector<std::string>{"", "a", "ab", "abc", "abcd", std::string("\0\xff\x10 z", 5)})
    EXPECT_EQ(studio::base64_decode(studio::base64_encode(s.data(), s.size())), s);
  EXPECT_EQ(studio::base64_encode("Man", 3), "TWFu");
  EXPECT_THROW(studio::base64_decode("TW*u"), Error);
}

TEST_F(Studio, InferAnswersWhatTheCliComputes) {
  const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
  auto r = client->Post("/api/infer", file_bytes(sketch), "image/png");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  EXPECT_EQ(r->get_header_value("Content-Type"), "application/octet-stream");
  const Heights got = parse_heights(r->body);
  model::GeneratorFile g = model::load_generator(kRoot / "models" / "reef-256.pt");
  infer::InferOptions io;
  const cv::Mat1f want = infer::infer_heights(g, {read_sketch(sketch)}, io)[0];
  ASSERT_EQ(got.h.size(), want.size());
  EXPECT_EQ(cv::norm(got.h, want, cv::NORM_INF), 0.0) << "the studio must give the CLI's heights";
  double lo = 0, hi = 0;
  cv::minMaxLoc(want, &lo, &hi);
  EXPECT_DOUBLE_EQ(got.meta["max_m"].get<double>(), hi);
  EXPECT_GT(got.meta["max_m"].get<double>(), 50.0) << "the painted island has land";
}

// ?seed=N is infer --seed: another island for the same painting, the CLI's
// heights for that seed; a bad seed is one 400 line naming the parameter.
TEST_F(Studio, ASeedReRollsTheIslandAsTheCliDoes) {
  const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
  const std::string png = file_bytes(sketch);
  auto r = client->Post("/api/infer?seed=5", png, "image/png");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Heights five = parse_heights(r->body);
  model::GeneratorFile g = model::load_generator(kRoot / "models" / "reef-256.pt");
  infer::InferOptions io;
  io.seed = 5;
  const cv::Mat1f want = infer::infer_heights(g, {read_sketch(sketch)}, io)[0];
  EXPECT_EQ(cv::norm(five.h, want, cv::NORM_INF), 0.0) << "the studio must give the CLI's heights for --seed 5";
  r = client->Post("/api/infer?seed=0", png, "image/png");
  ASSERT_TRUE(r && r->status == 200);
  EXPECT_GT(cv::norm(parse_heights(r->body).h, five.h, cv::NORM_INF), 10.0) << "another seed, another island";
  for (const std::string bad : {"-1", "abc", "18446744073709551616", "1e3", ""}) {
    r = client->Post("/api/infer?seed=" + bad, png, "image/png");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 400) << bad;
    EXPECT_NE(r->body.find("seed must be a whole number"), std::string::npos) << bad << ": " << r->body;
  }
}

// ?age_myr=T is infer --age-myr: the CLI's heights for that age; a bad age
// is one 400 line naming the parameter.
TEST_F(Studio, AnAgeIsTheCliAge) {
  infer::InferOptions io;
  io.seed = 2;
  io.age_myr = 3.5;
  const auto [got, want] = studio_and_cli("seed=2&age_myr=3.5", io);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0) << "the studio must give --age-myr 3.5's heights";
  expect_refused("age_myr", {"-1", "61", "abc", "1e3", "", "3.5.1"}, "age_myr must be");
}

// ?maturity=M is infer --maturity (the erosion's maturity alone: the
// painting keeps its subsidence) — what the page's Age and Maturity sliders
// send; a bad maturity is one 400 line naming the parameter.
TEST_F(Studio, AMaturityIsTheCliMaturity) {
  infer::InferOptions io;
  io.seed = 1;
  io.maturity = 0.25;
  const auto [got, want] = studio_and_cli("seed=1&maturity=0.25", io);
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(cv::norm(got, want, cv::NORM_INF), 0.0) << "the studio must give --maturity 0.25's heights";
  io.maturity = kNotSet;
  const cv::Mat1f unset = studio_and_cli("seed=1", io).second;
  EXPECT_GT(cv::norm(got, unset, cv::NORM_INF), 1.0) << "a maturity of 0.25 must change the island";
  expect_refused("maturity", {"0.01", "21", "abc", "-1", "", "1e1"}, "maturity must be");
}

// A burst of inference requests, some of them corrupt: every one is answered
// (200, 409 when a newer one superseded it, 400 for the corrupt ones), and
// afterwards the studio still answers with the CLI's heights — the decode
// slots (at most two decoded sketches held at once) are given back on every
// path, errors included.
TEST_F(Studio, ABurstOfInferRequestsIsAnsweredAndLeavesNoSlotHeld) {
  const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
  const std::string png = file_bytes(sketch);
  std::vector<int> status(12, 0);
  std::vector<std::thread> burst;
  for (size_t i = 0; i < status.size(); ++i)
    burst.emplace_back([&, i] {
      httplib::Client c("127.0.0.1", port);
      c.set_read_timeout(120, 0);
      const bool corrupt = i % 3 == 1;
      auto r = c.Post("/api/infer", corrupt ? png.substr(0, png.size() / 2) : png, "image/png");
      status[i] = r ? r->status : -1;
    });
  for (auto& t : burst) t.join();
  // The newest request is never superseded, so at least one answer is not a
  // 409; it may be a corrupt one (400) when that arrived last.
  int answered = 0;
  for (size_t i = 0; i < status.size(); ++i) {
    if (i % 3 == 1) {
      EXPECT_TRUE(status[i] == 400 || status[i] == 409) << i << ": " << status[i];
    } else {
      EXPECT_TRUE(status[i] == 200 || status[i] == 409) << i << ": " << status[i];
    }
    answered += status[i] == 200 || status[i] == 400;
  }
  EXPECT_GE(answered, 1);
  auto r = client->Post("/api/infer", png, "image/png");
  ASSERT_TRUE(r) << "the studio stopped answering after the burst";
  ASSERT_EQ(r->status, 200) << r->body;
  model::GeneratorFile g = model::load_generator(kRoot / "models" / "reef-256.pt");
  infer::InferOptions io;
  EXPECT_EQ(cv::norm(parse_heights(r->body).h, infer::infer_heights(g, {read_sketch(sketch)}, io)[0], cv::NORM_INF), 0.0);
}

// Transparent pixels are open ocean whatever their colour,
// through the raw canvas path as through a PNG with alpha (the raw path
// dropped alpha: transparent yellow came out +377 m high).
TEST_F(Studio, RawCanvasAlphaIsThePngsAlpha) {
  const cv::Mat bgr = cv::imread((kRoot / "docs" / "examples" / "painted-sketch.png").string(), cv::IMREAD_COLOR);
  cv::Mat bgra;
  cv::cvtColor(bgr, bgra, cv::COLOR_BGR2BGRA);
  // The top-left quarter: transparent island yellow.
  bgra(cv::Rect(0, 0, bgra.cols / 2, bgra.rows / 2)).setTo(cv::Scalar(0, 255, 255, 0));
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", bgra, png));
  cv::Mat rgba;
  cv::cvtColor(bgra, rgba, cv::COLOR_BGRA2RGBA);
  const std::string raw(reinterpret_cast<const char*>(rgba.data), rgba.total() * 4);
  auto r = client->Post("/api/infer?w=" + std::to_string(rgba.cols) + "&h=" + std::to_string(rgba.rows), raw,
                        "application/x-reefgen-rgba");
  auto p = client->Post("/api/infer", std::string(png.begin(), png.end()), "image/png");
  ASSERT_TRUE(r && p);
  ASSERT_EQ(r->status, 200) << r->body;
  ASSERT_EQ(p->status, 200) << p->body;
  const cv::Mat1f raw_h = parse_heights(r->body).h, png_h = parse_heights(p->body).h;
  EXPECT_EQ(cv::norm(raw_h, png_h, cv::NORM_INF), 0.0);
  double top = 0;
  cv::minMaxLoc(raw_h(cv::Rect(0, 0, raw_h.cols / 4, raw_h.rows / 4)), nullptr, &top);
  EXPECT_LT(top, 0.0) << "transparent paint must be sea";
}

TEST_F(Studio, RawCanvasPixelsGiveThePngsHeights) {
  // The page sends its canvas as raw RGBA (no PNG encoding on its main
  // thread): the same pixels must give the same heights as the PNG.
  const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
  const cv::Mat bgr = cv::imread(sketch.string(), cv::IMREAD_COLOR);
  cv::Mat rgba;
  cv::cvtColor(bgr, rgba, cv::COLOR_BGR2RGBA);
  const std::string raw(reinterpret_cast<const char*>(rgba.data), rgba.total() * 4);
  const std::string q = "/api/infer?w=" + std::to_string(bgr.cols) + "&h=" + std::to_string(bgr.rows);
  auto r = client->Post(q, raw, "application/x-reefgen-rgba");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  auto p = client->Post("/api/infer", file_bytes(sketch), "image/png");
  ASSERT_TRUE(p);
  ASSERT_EQ(p->status, 200) << p->body;
  EXPECT_EQ(cv::norm(parse_heights(r->body).h, parse_heights(p->body).h, cv::NORM_INF), 0.0);
  // ?enc=u16 (what the page asks for): half the bytes, heights within half a step.
  auto u = client->Post(q + "&enc=u16", raw, "application/x-reefgen-rgba");
  ASSERT_TRUE(u);
  ASSERT_EQ(u->status, 200) << u->body;
  {
    uint32_t n = 0;
    for (int i = 0; i < 4; ++i) n |= uint32_t(uint8_t(u->body[size_t(i)])) << (8 * i);
    const json meta = json::parse(u->body.substr(4, n));
    ASSERT_EQ(meta.at("encoding"), "u16");
    const int s = meta.at("size");
    ASSERT_EQ(u->body.size(), 4 + n + size_t(s) * size_t(s) * 2);
    cv::Mat1w qh(s, s);
    std::memcpy(qh.ptr<uint16_t>(), u->body.data() + 4 + n, size_t(s) * size_t(s) * 2);
    cv::Mat1f back;
    qh.convertTo(back, CV_32F, double(meta.at("u16_step_m")), double(meta.at("u16_lo_m")));
    const cv::Mat1f f32 = parse_heights(p->body).h;
    EXPECT_LE(cv::norm(back, f32, cv::NORM_INF), 0.5 * double(meta.at("u16_step_m")) + 1e-3);
    EXPECT_LT(double(meta.at("u16_step_m")), 0.02);  // metres: finer than the view can show
  }
  // Wrong byte count, missing or out-of-range sides: 400 naming the fix.
  expect_error(client->Post(q, raw.substr(1), "application/x-reefgen-rgba"), 400, "send w·h·4 bytes");
  expect_error(client->Post("/api/infer?w=256", raw, "application/x-reefgen-rgba"), 400, "?h=");
  expect_error(client->Post("/api/infer?w=99999&h=1", raw, "application/x-reefgen-rgba"), 400, "w = 99999");
  expect_error(client->Post("/api/infer?w=-5&h=256", raw, "application/x-reefgen-rgba"), 400, "?w=");
}

// Ctrl-C while a request is computed (the studio's hook, cmd_studio.cpp,
// throws Interrupted once a stop is asked): that request is answered a
// one-line 503 at the work's next step, and the studio serves on after.
namespace {
std::atomic<bool> g_stop_asked{false};
}
TEST_F(Studio, AStopAskedDuringARequestIsAnswered503) {
  set_interrupt_hook(+[] {
    if (g_stop_asked) throw Interrupted();
  });
  g_stop_asked = true;
  expect_error(client->Post("/api/generate?size=128", "{}", "application/json"), 503, "the studio is stopping");
  g_stop_asked = false;
  auto r = client->Post("/api/generate?size=128", "{}", "application/json");
  set_interrupt_hook(nullptr);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200) << r->body;
}

TEST_F(Studio, GenerateAnswersWhatTheGeneratorComputes) {
  const std::string spec = R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98], "subsidence": 0.3})";
  auto r = client->Post("/api/generate?size=128", spec, "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const Heights got = parse_heights(r->body);
  procgen::RenderOptions ro;
  ro.size_px = 128;
  const auto f = procgen::generate(procgen::spec_from_json(json::parse(spec), "spec"), ro);
  EXPECT_EQ(cv::norm(got.h, f.height_m, cv::NORM_INF), 0.0);
  const std::string png = studio::base64_decode(got.meta["label_png"]);
  const cv::Mat label = cv::imdecode(std::vector<uchar>(png.begin(), png.end()), cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(label, encode_labels(f.label, 0.3), cv::NORM_INF), 0.0);
  auto p = client->Get("/api/presets");
  ASSERT_TRUE(p);
  EXPECT_TRUE(json::parse(p->body).contains("round"));
  auto info = client->Get("/api/info");
  ASSERT_TRUE(info);
  EXPECT_EQ(json::parse(info->body)["model"]["size_px"], 256);
}

TEST_F(Studio, ExportsWriteOnlyIntoTheOutputFolder) {
  const std::string sketch = file_bytes(kRoot / "docs" / "examples" / "painted-sketch.png");
  const json body = {{"sketch_png", studio::base64_encode(sketch.data(), sketch.size())}};
  for (const char* f : {"exr", "png16", "r16", "glb", "obj", "sketch"}) {
    auto r = client->Post(std::string("/api/export?format=") + f + "&name=isle", body.dump(), "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << f << ": " << r->body;
    const fs::path written = r->get_header_value("X-Reefgen-Path");
    EXPECT_EQ(fs::canonical(written).parent_path(), fs::canonical(out / "exports")) << f;
    EXPECT_EQ(file_bytes(written), r->body) << f << ": the download is the file written";
  }
  EXPECT_EQ(read_exr_height(out / "exports" / "isle.height.exr").cols, 256);
  EXPECT_EQ(fs::file_size(out / "exports" / "isle.r16"), 257u * 257u * 2) << "Unity sizes: 2^n + 1";
  // One import note per 16-bit format (an R16 then a PNG16 shared one note,
  // the second describing a 256² file beside a 257² R16).
  const json r16_note = read_json(out / "exports" / "isle.r16.import.json");
  const json png_note = read_json(out / "exports" / "isle.png16.import.json");
  EXPECT_EQ(r16_note["unity"]["resolution"][0], 257);
  EXPECT_EQ(png_note["unity"]["resolution"][0], 256);
  EXPECT_FALSE(fs::exists(out / "exports" / "isle.import.json"));
  EXPECT_EQ(file_bytes(out / "exports" / "isle.glb").substr(0, 4), "glTF");
  const json spec_body = {{"spec", json::parse(R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98]})")}, {"size", 64}};
  auto s = client->Post("/api/export?format=spec&name=mine", spec_body.dump(), "application/json");
  ASSERT_TRUE(s);
  ASSERT_EQ(s->status, 200) << s->body;
  EXPECT_NO_THROW(procgen::spec_from_json(read_json(out / "exports" / "mine.spec.json"), "round trip"));
  // Names that would leave the folder, or hide in it, are refused; nothing is written.
  for (const char* name : {"../evil", "..", "a/b", "%2e%2e%2fx", ".hidden", ""}) {
    auto r = client->Post(std::string("/api/export?format=exr&name=") + name, body.dump(), "application/json");
    expect_error(r, 400, "name");
  }
  EXPECT_FALSE(fs::exists(out / "evil.height.exr"));
  expect_error(client->Post("/api/export?format=tiff&name=x", body.dump(), "application/json"), 400, "format 'tiff'");
  // Bundles: the folder beside the other exports, and one ZIP of this export's files.
  for (const char* e : {"unity", "unreal", "godot", "blender", "gis"}) {
    auto r = client->Post(std::string("/api/export?format=") + e + "&name=isle", spec_body.dump(), "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << e << ": " << r->body;
    const fs::path folder = out / "exports" / (std::string("isle.") + e);
    EXPECT_EQ(fs::canonical(r->get_header_value("X-Reefgen-Path")), fs::canonical(folder)) << e;
    EXPECT_EQ(r->body.substr(0, 4), std::string("PK\x03\x04", 4)) << e;
    for (const auto& f : fs::directory_iterator(folder))
      EXPECT_NE(r->body.find(std::string("isle.") + e + "/" + f.path().filename().string()), std::string::npos)
          << e << ": the ZIP lacks " << f.path().filename();
  }
  EXPECT_EQ(fs::file_size(out / "exports" / "isle.unity" / "isle.raw"), 65u * 65u * 2) << "64² → Unity's 65²";
  {
    auto r = client->Post("/api/export?format=unity&name=isle", spec_body.dump(), "application/json");
    ASSERT_TRUE(r);
    EXPECT_NE(r->get_header_value("X-Reefgen-Note").find("resampled to 65²"), std::string::npos) << "no size note";
  }
  // Layer pictures: the island's size, different per view; unknown views refused.
  std::string pictures[2];
  for (int k = 0; k < 2; ++k) {
    auto r = client->Post(std::string("/api/layers?view=") + (k ? "flow" : "materials"), spec_body.dump(), "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const cv::Mat img = cv::imdecode(std::vector<uchar>(r->body.begin(), r->body.end()), cv::IMREAD_COLOR);
    ASSERT_EQ(img.cols, 64);
    pictures[k] = r->body;
  }
  EXPECT_NE(pictures[0], pictures[1]);
  expect_error(client->Post("/api/layers?view=wear", spec_body.dump(), "application/json"), 400, "view 'wear'");
  // The rain the erosion read: a picture where the spec has a wind, one
  // line where it has none.
  expect_error(client->Post("/api/layers?view=rain", spec_body.dump(), "application/json"), 400, "no rain from a wind");
  {
    json windy = spec_body;
    windy["spec"]["wind"] = json::parse(R"([{"points": [[-0.9, 0.0], [0.0, 0.05]], "strength": 0.3, "width": 0.2}])");
    auto r = client->Post("/api/layers?view=rain", windy.dump(), "application/json");
    ASSERT_TRUE(r);
    ASSERT_EQ(r->status, 200) << r->body;
    const cv::Mat img = cv::imdecode(std::vector<uchar>(r->body.begin(), r->body.end()), cv::IMREAD_COLOR);
    ASSERT_EQ(img.cols, 64);
    EXPECT_NE(r->body, pictures[1]) << "the rain drawn as the flow";
  }
  expect_error(client->Post("/api/export?format=spec&name=x", body.dump(), "application/json"), 400, "needs a spec");
  // Static files: no path outside the page's folder.
  auto t = client->Get("/../../etc/passwd");
  ASSERT_TRUE(t);
  EXPECT_NE(t->status, 200);
  auto idx = client->Get("/");
  ASSERT_TRUE(idx);
  EXPECT_EQ(idx->status, 200);
  EXPECT_NE(idx->body.find("reefgen studio"), std::string::npos);
}

// An export's ocean_floor_m is the CLI's --ocean-floor-m: the open ocean's
// flank continued towards it (terrain/ocean_floor.hpp), nothing above the
// flank's knee moved; a bad depth is a 400 naming the field.
TEST_F(Studio, ExportsContinueTheFlankToTheOceanFloorAsked) {
  const json spec = json::parse(R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98]})");
  json body = {{"spec", spec}, {"size", 64}};
  auto plain = client->Post("/api/export?format=exr&name=shallow", body.dump(), "application/json");
  ASSERT_TRUE(plain);
  ASSERT_EQ(plain->status, 200) << plain->body;
  body["ocean_floor_m"] = -1500;
  auto deep = client->Post("/api/export?format=exr&name=deep", body.dump(), "application/json");
  ASSERT_TRUE(deep);
  ASSERT_EQ(deep->status, 200) << deep->body;
  const cv::Mat1f a = read_exr_height(out / "exports" / "shallow.height.exr");
  const cv::Mat1f b = read_exr_height(out / "exports" / "deep.height.exr");
  double lo_a, lo_b;
  cv::minMaxLoc(a, &lo_a);
  cv::minMaxLoc(b, &lo_b);
  EXPECT_GE(lo_a, -100.0);
  EXPECT_GE(lo_b, -1500.0);
  EXPECT_LT(lo_b, -500.0);  // the 6 km canvas's corners, kilometres from the reef
  const cv::Mat1b shallow = a > terrain::kFlankKneeM;
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF, shallow), 0.0);
  for (const json& bad : {json(-20000), json("deep"), json(5)}) {
    body["ocean_floor_m"] = bad;
    expect_error(client->Post("/api/export?format=exr&name=bad", body.dump(), "application/json"), 400, "ocean_floor_m");
  }
  EXPECT_FALSE(fs::exists(out / "exports" / "bad.height.exr"));
}

// A bundle folder that is a link out of --out is refused; nothing is written
// where it points.
TEST_F(Studio, BundleExportsDoNotFollowLinksOutOfTheFolder) {
  const fs::path elsewhere = out / "elsewhere";
  fs::create_directories(elsewhere);
  write_text_atomic(elsewhere / "README.txt", "mine");
  fs::create_directories(out / "exports");
  fs::create_directory_symlink(elsewhere, out / "exports" / "v2.godot");
  const json body = {{"spec", json::parse(R"({"outlines": [0.3, 0.38, 0.55, 0.68, 0.98]})")}, {"size", 64}};
  expect_error(client->Post("/api/export?format=godot&name=v2", body.dump(), "application/json"), 400, "link");
  EXPECT_EQ(read_text(elsewhere / "README.txt"), "mine");
  EXPECT_EQ(std::distance(fs::directory_iterator(elsewhere), fs::directory_iterator()), 1);
}

TEST_F(Studio, BadAndOversizeRequestsAreRefused) {
  expect_error(client->Post("/api/infer", "not an image", "image/png"), 400, "not an image");
  expect_error(client->Post("/api/infer", "", "image/png"), 400, "empty body");
  // Larger than --max-side (1024).
  cv::Mat3b big(1100, 1100, cv::Vec3b(0, 0, 255));
  std::vector<uchar> png;
  cv::imencode(".png", big, png);
  expect_error(client->Post("/api/infer", std::string(png.begin(), png.end()), "image/png"), 400, "at most 1024");
  // A body over the limit (1 MiB here): 413, before any decoding.
  auto r = client->Post("/api/infer", std::string(2 << 20, 'x'), "image/png");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 413);
  // An image without any region colour, a broken spec, a spec with a bad value.
  cv::Mat3b grey(64, 64, cv::Vec3b(128, 128, 128));
  cv::imencode(".png", grey, png);
  auto g = client->Post("/api/infer", std::string(png.begin(), png.end()), "image/png");
  ASSERT_TRUE(g);
  EXPECT_EQ(g->status, 400) << g->body;
  expect_error(client->Post("/api/generate", "{\"outlines\": [", "application/json"), 400, "not valid JSON");
  expect_error(client->Post("/api/generate", R"({"subsidence": 7})", "application/json"), 400, "subsidence = 7");
  expect_error(client->Post("/api/generate?size=5000", "{}", "application/json"), 400, "size must be");
  // A size past 2^32 wrapped to 32 and was answered.
  expect_error(client->Post("/api/generate?size=4294967328", "{}", "application/json"), 400, "size must be");
  expect_error(client->Post("/api/generate?size=128px", "{}", "application/json"), 400, "size must be");
  expect_error(client->Post("/api/generate?size=-128", "{}", "application/json"), 400, "size must be");
}

namespace {

// One raw HTTP exchange on loopback: what a hostile client (or a browser on
// another site) sends, byte for byte. Returns the status code and the body.
std::pair<int, std::string> raw_request(int port, const std::string& request) {
  httplib::Client c("127.0.0.1", port);  // only to know the server is up
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return {-1, "connect failed"};
  }
  timeval tv{10, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  for (size_t sent = 0; sent < request.size();) {
    const ssize_t n = ::send(fd, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) break;  // the server may answer and close before reading it all
    sent += size_t(n);
  }
  std::string resp;
  char buf[4096];
  for (ssize_t n; (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) {
    resp.append(buf, size_t(n));
    const size_t head_end = resp.find("\r\n\r\n");
    if (head_end == std::string::npos) continue;
    const size_t cl = resp.find("Content-Length: ");
    if (cl != std::string::npos && cl < head_end &&
        resp.size() >= head_end + 4 + std::stoul(resp.substr(cl + 16)))
      break;
  }
  ::close(fd);
  if (resp.rfind("HTTP/1.1 ", 0) != 0) return {-1, resp};
  const size_t head_end = resp.find("\r\n\r\n");
  return {std::stoi(resp.substr(9, 3)), head_end == std::string::npos ? "" : resp.substr(head_end + 4)};
}

std::string post(int port, const std::string& path, const std::string& headers, const std::string& body) {
  return "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\n" + headers +
         "Content-Length: " + std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
}

}  // namespace

// A web page the user visits must not drive the studio (CSRF, DNS
// rebinding), and no body gets past the limit however it is sent.
TEST_F(Studio, CrossOriginAndRebindingRequestsAreRefused) {
  const std::string spec = R"({"spec": {}, "size": 64})";
  const std::string path = "/api/export?format=spec&name=csrf";
  // A "simple" cross-origin POST (text/plain: no CORS preflight) from another site.
  auto [st, body] = raw_request(port, post(port, path, "Origin: http://evil.example\r\nContent-Type: text/plain\r\n", spec));
  EXPECT_EQ(st, 403) << body;
  EXPECT_NE(body.find("cross-origin"), std::string::npos) << body;
  // Sec-Fetch-Site without Origin (some browsers on some requests).
  std::tie(st, body) = raw_request(port, post(port, path, "Sec-Fetch-Site: cross-site\r\n", spec));
  EXPECT_EQ(st, 403) << body;
  // DNS rebinding: the attacker's name resolves to 127.0.0.1; Host is its name.
  const std::string rebound = "GET /api/info HTTP/1.1\r\nHost: evil.example:" + std::to_string(port) +
                              "\r\nConnection: close\r\n\r\n";
  std::tie(st, body) = raw_request(port, rebound);
  EXPECT_EQ(st, 403) << body;
  std::tie(st, body) = raw_request(port, "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:1\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(st, 403) << "another port is another origin: " << body;
  EXPECT_FALSE(fs::exists(out / "exports" / "csrf.spec.json"));
  // The page's own origin (and localhost) still works.
  std::tie(st, body) = raw_request(
      port, post(port, path, "Origin: http://127.0.0.1:" + std::to_string(port) + "\r\nContent-Type: application/json\r\n", spec));
  EXPECT_EQ(st, 200) << body;
  EXPECT_TRUE(fs::exists(out / "exports" / "csrf.spec.json"));
  std::tie(st, body) = raw_request(port, "GET /api/info HTTP/1.1\r\nHost: localhost:" + std::to_string(port) +
                                             "\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(st, 200) << body;
}

// Two different Content-Length headers are a 400 (RFC 7230 §3.3.3).
TEST_F(Studio, TwoDifferentContentLengthsAreRefused) {
  const std::string spec = "{}";
  const std::string head = "POST /api/generate?size=64 HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                           "\r\nContent-Type: application/json\r\nConnection: close\r\n";
  auto [st, body] = raw_request(port, head + "Content-Length: 2\r\nContent-Length: 7\r\n\r\n" + spec);
  EXPECT_EQ(st, 400) << body;
  EXPECT_NE(body.find("Content-Length"), std::string::npos) << body;
  // The same value twice is allowed (RFC 7230 lets a recipient merge them).
  std::tie(st, body) = raw_request(port, head + "Content-Length: 2\r\nContent-Length: 2\r\n\r\n" + spec);
  EXPECT_EQ(st, 200) << body;
}

TEST_F(Studio, BodiesOverTheLimitAreRefusedHoweverSent) {
  // Chunked: the HTTP library would read it without bound.
  std::string chunked = "POST /api/infer HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                        "\r\nTransfer-Encoding: chunked\r\nContent-Type: image/png\r\nConnection: close\r\n\r\n";
  for (int i = 0; i < 8; ++i) chunked += "40000\r\n" + std::string(0x40000, 'x') + "\r\n";  // 2 MiB > 1 MiB
  chunked += "0\r\n\r\n";
  auto [st, body] = raw_request(port, chunked);
  EXPECT_EQ(st, 411) << body;
  EXPECT_NE(body.find("Content-Length"), std::string::npos) << body;
  // Content-Length over the limit: 413 with a one-line JSON body (was empty).
  expect_error(client->Post("/api/infer", std::string(2 << 20, 'x'), "application/octet-stream"), 413, "too large");
  // Form encodings: refused by type, whatever the size (was 413 above 8 KiB).
  expect_error(client->Post("/api/infer", std::string(9000, 'a'), "application/x-www-form-urlencoded"), 415,
               "application/json");
}

TEST_F(Studio, MalformedFieldsAre400WithOneReadableLine) {
  expect_error(client->Post("/api/export?format=exr&name=a", R"({"sketch_png": 42})", "application/json"), 400,
               "sketch_png must be a string");
  expect_error(client->Post("/api/export?format=exr&name=a", R"({"sketch_png": "@@@"})", "application/json"), 400,
               "base64");
  expect_error(client->Post("/api/export?format=spec&name=a", R"({"spec": {}, "size": "big"})", "application/json"), 400,
               "size must be");
  // A NUL in the name is shown, not allowed to cut the message.
  expect_error(client->Post("/api/export?format=spec&name=a%00b", R"({"spec": {}})", "application/json"), 400,
               "a\\x00b");
  EXPECT_TRUE(!fs::exists(out / "exports") || fs::is_empty(out / "exports"));
}

TEST_F(Studio, OnlyThePagesOwnFilesAreServed) {
  auto r = client->Get("/");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  EXPECT_NE(r->get_header_value("Content-Type").find("text/html"), std::string::npos);
  // A link inside the page's folder is not followed, even when made after start.
  const fs::path link = fs::path(REEFGEN_STUDIO_ASSETS) / "probe-link.txt";
  std::error_code ec;
  fs::remove(link, ec);
  fs::create_symlink("/etc/hostname", link);
  r = client->Get("/probe-link.txt");
  fs::remove(link, ec);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  // A NUL in the path does not pick a content type from what follows it.
  r = client->Get("/index.html%00.png");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
  EXPECT_EQ(r->get_header_value("Content-Type").find("image/png"), std::string::npos);
  r = client->Get("/../../etc/passwd");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 404);
}

TEST_F(Studio, StalledClientsDoNotBlockThePage) {
  std::vector<int> stalled;
  for (int i = 0; i < 16; ++i) {  // more than the HTTP library's default 8 workers
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(uint16_t(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ASSERT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    const std::string half = "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1\r\n";  // never finished
    ASSERT_GT(::send(fd, half.data(), half.size(), MSG_NOSIGNAL), 0);
    stalled.push_back(fd);
  }
  httplib::Client c("127.0.0.1", port);
  c.set_read_timeout(5, 0);
  c.set_connection_timeout(5, 0);
  auto r = c.Get("/api/info");
  for (int fd : stalled) ::close(fd);
  ASSERT_TRUE(r) << "the server did not answer within 5 s with 16 stalled connections";
  EXPECT_EQ(r->status, 200);
}

TEST_F(Studio, ASecondServerCannotTakeTheSamePort) {
  studio::StudioOptions o;
  o.port = port;
  o.model = kRoot / "models" / "reef-256.pt";
  o.out_dir = out / "exports2";
  o.assets_dir = REEFGEN_STUDIO_ASSETS;
  o.precision = "fp32";
  studio::StudioServer second(o);
  test::expect_error_naming([&] { second.bind(); }, "cannot listen on 127.0.0.1:" + std::to_string(port));
}

TEST(StudioOptions, AnOutputFolderThatIsAFileIsRefusedAtStart) {
  const fs::path dir = test::temp_dir("studio-out");
  write_text_atomic(dir / "file", "x");
  studio::StudioOptions o;
  o.port = 0;
  o.model = kRoot / "models" / "reef-256.pt";
  o.out_dir = dir / "file";
  o.assets_dir = REEFGEN_STUDIO_ASSETS;
  test::expect_error_naming([&] { studio::StudioServer s(o); }, "is a file, not a folder");
  fs::remove_all(dir);
}

// Clients that trickle their request heads (slowloris) hold
// no worker. 200 of them connected, a normal request is still answered (the
// library alone gave each a worker until its 10 s read timeout: 64 workers,
// every later request waited); each slow one gets 408 at the head deadline,
// one that keeps trickling included.
TEST_F(Studio, SlowClientsNeitherStarveTheStudioNorOutstayTheHeadDeadline) {
  std::vector<int> slow;
  for (int i = 0; i < 200; ++i) {
    const int fd = open_partial(port, "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\nX-A: ");
    ASSERT_GE(fd, 0) << "slow client " << i;
    slow.push_back(fd);
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto r = client->Get("/api/info");
  const double waited_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  // Liveness, not speed: well under the head deadline the slow ones get.
  EXPECT_LT(waited_s, kHeadDeadlineMs / 1000.0) << "a normal request waited behind the slow clients";
  // One that keeps trickling a byte every 100 ms is cut off all the same.
  const int trickler = slow.back();
  for (int i = 0; i < 5; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    ASSERT_EQ(::send(trickler, "x", 1, MSG_NOSIGNAL), 1);
  }
  for (const int fd : {slow.front(), trickler}) {
    const std::string answer = read_for(fd, kHeadDeadlineMs + 3000);
    EXPECT_EQ(answer.rfind("HTTP/1.1 408", 0), 0u) << answer;
    EXPECT_NE(answer.find("request head not received within 2000 ms"), std::string::npos) << answer;
  }
  for (const int fd : slow) ::close(fd);
  r = client->Get("/api/info");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

// Out of file descriptors (a flood of connections, a low ulimit): each new
// client is answered 503 naming the cause from a descriptor held in reserve,
// rather than left in the backlog while the front door retries accept; the
// studio serves again once descriptors are free.
TEST_F(Studio, OutOfFileDescriptorsIsA503NamingIt) {
  std::vector<int> clients;
  for (int i = 0; i < 3; ++i) clients.push_back(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  rlimit was{};
  ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &was), 0);
  rlimit low = was;
  low.rlim_cur = std::min<rlim_t>(was.rlim_cur, 1024);
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &low), 0);
  std::vector<int> fillers;  // every free descriptor below the limit
  for (int fd; (fd = ::open("/dev/null", O_RDONLY | O_CLOEXEC)) >= 0;) fillers.push_back(fd);
  const int open_errno = errno;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(uint16_t(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const std::string request = "GET /api/info HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) + "\r\n\r\n";
  std::vector<std::string> answers;
  for (const int fd : clients) {
    const bool sent = ::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
                      ::send(fd, request.data(), request.size(), MSG_NOSIGNAL) == ssize_t(request.size());
    answers.push_back(sent ? read_for(fd, 3000) : "not sent");
  }
  for (const int fd : fillers) ::close(fd);
  ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &was), 0);
  for (const int fd : clients) ::close(fd);
  EXPECT_EQ(open_errno, EMFILE);
  for (const std::string& answer : answers) {
    EXPECT_EQ(answer.rfind("HTTP/1.1 503", 0), 0u) << answer;
    EXPECT_NE(answer.find("out of file descriptors"), std::string::npos) << answer;
  }
  const auto r = client->Get("/api/info");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
}

TEST(StudioZip, StoredArchiveHasTheFilesAndTheirCrcs) {
  const std::string zip = studio::zip_stored({{"a/hello.txt", "hello"}, {"a/empty", ""}});
  auto u16 = [&](size_t at) { return unsigned(uint8_t(zip[at])) | unsigned(uint8_t(zip[at + 1])) << 8; };
  auto u32 = [&](size_t at) { return u16(at) | u16(at + 2) << 16; };
  // Local header of the first file: signature, stored, CRC-32 of "hello" (golden), sizes, name, bytes.
  EXPECT_EQ(u32(0), 0x04034b50u);
  EXPECT_EQ(u16(8), 0u);
  EXPECT_EQ(u32(14), 0x3610a686u);
  EXPECT_EQ(u32(18), 5u);
  EXPECT_EQ(u32(22), 5u);
  EXPECT_EQ(zip.substr(30, 11), "a/hello.txt");
  EXPECT_EQ(zip.substr(41, 5), "hello");
  // End record: two entries, and the central directory where it says.
  const size_t end = zip.size() - 22;
  EXPECT_EQ(u32(end), 0x06054b50u);
  EXPECT_EQ(u16(end + 10), 2u);
  const size_t central = u32(end + 16);
  EXPECT_EQ(u32(central), 0x02014b50u);
  EXPECT_EQ(u32(central + 16), 0x3610a686u);
  EXPECT_EQ(u32(central + 42), 0u) << "the first file's local header offset";
  EXPECT_EQ(u32(end + 12), zip.size() - 22 - central) << "central directory size";
  // Deterministic: the same files give the same bytes.
  EXPECT_EQ(zip, studio::zip_stored({{"a/hello.txt", "hello"}, {"a/empty", ""}}));
  EXPECT_THROW(studio::zip_stored({{"", "x"}}), Error);
}

namespace {
// A PNG whose header declares side² pixels and whose body is `filler`
// bytes of zeros (a hostile upload: small on the wire, huge decoded).
std::string png_declaring(uint32_t side, size_t filler) {
  const auto be32 = [](uint32_t v) {
    return std::string{char(v >> 24), char(v >> 16 & 0xff), char(v >> 8 & 0xff), char(v & 0xff)};
  };
  const auto chunk = [&](const std::string& type, const std::string& data) {
    const std::string td = type + data;
    return be32(uint32_t(data.size())) + td +
           be32(uint32_t(crc32(0, reinterpret_cast<const Bytef*>(td.data()), uInt(td.size()))));
  };
  const std::string ihdr = be32(side) + be32(side) + std::string("\x08\x02\x00\x00\x00", 5);
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", std::string(filler, '\0')) +
         chunk("IEND", "");
}
}  // namespace

// Eight uploads at once to each image route, each a PNG declaring 30000²
// (2.7 GB decoded): every one refused in one line from its header, none
// decoded, and the studio answers an island afterwards.
TEST_F(Studio, HugeDeclaredImagesAreRefusedOnEveryRouteAtOnce) {
  const std::string png = png_declaring(30000, 200000);
  const std::string b64 = json{{"sketch_png", studio::base64_encode(png.data(), png.size())}}.dump();
  struct Route {
    std::string path, body, type;
  };
  const std::vector<Route> routes = {{"/api/infer", png, "image/png"},
                                     {"/api/layers?view=flow", b64, "application/json"},
                                     {"/api/export?format=exr&name=huge", b64, "application/json"}};
  std::vector<std::unique_ptr<httplib::Result>> answers(routes.size() * 8);
  std::vector<std::thread> burst;
  for (size_t i = 0; i < answers.size(); ++i)
    burst.emplace_back([&, i] {
      httplib::Client c("127.0.0.1", port);
      c.set_read_timeout(60, 0);
      const Route& r = routes[i % routes.size()];
      answers[i] = std::make_unique<httplib::Result>(c.Post(r.path, r.body, r.type));
    });
  for (auto& t : burst) t.join();
  for (size_t i = 0; i < answers.size(); ++i) {
    SCOPED_TRACE(routes[i % routes.size()].path);
    expect_error(*answers[i], 400, "30000×30000 pixels; at most 1024");
  }
  EXPECT_FALSE(fs::exists(out / "exports" / "huge.height.exr"));
  const std::string sketch = file_bytes(kRoot / "docs" / "examples" / "painted-sketch.png");
  auto r = client->Post("/api/infer", sketch, "image/png");
  ASSERT_TRUE(r) << "the studio stopped answering";
  EXPECT_EQ(r->status, 200) << r->body;
}

// Variations: the next n seeds' islands as hill-shaded pictures, each the
// preview of the island /api/infer draws with that seed; n is bounded.
TEST_F(Studio, VariationsDrawTheIslandsOfTheNextSeeds) {
  const fs::path sketch = kRoot / "docs" / "examples" / "painted-sketch.png";
  const std::string png = file_bytes(sketch);
  auto r = client->Post("/api/variations?n=3&seed=7", png, "image/png");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 200) << r->body;
  const json j = json::parse(r->body);
  ASSERT_EQ(j["seeds"], json({7, 8, 9}));
  ASSERT_EQ(j["previews"].size(), 3u);
  std::vector<cv::Mat> pics;
  for (const auto& p : j["previews"]) {
    const std::string bytes = studio::base64_decode(p.get<std::string>());
    pics.push_back(cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_COLOR));
    ASSERT_FALSE(pics.back().empty());
  }
  EXPECT_GT(cv::norm(pics[0], pics[1], cv::NORM_L1), 0.0) << "two seeds, one picture";
  // The second picture is the island /api/infer gives with seed 8.
  auto one = client->Post("/api/infer?seed=8", png, "image/png");
  ASSERT_TRUE(one && one->status == 200);
  const std::string want = encode_png8(render_preview(parse_heights(one->body).h), 1);
  EXPECT_EQ(studio::base64_decode(j["previews"][1].get<std::string>()), want);
  expect_error(client->Post("/api/variations?n=99", png, "image/png"), 400, "n must be a whole number from 2 to 8");
  expect_error(client->Post("/api/variations?n=x", png, "image/png"), 400, "n must be");
}
