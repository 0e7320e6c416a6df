#include "reefgen/studio/server.hpp"

#include <arpa/inet.h>
#include <httplib.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cerrno>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <cmath>
#include <mutex>
#include <regex>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/interrupt.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/version.hpp"
#include "reefgen/studio/front_door.hpp"
#include "reefgen/engines/bundle.hpp"
#include "reefgen/studio/zip.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/terrain/ocean_floor.hpp"

namespace reefgen::studio {

using json = nlohmann::json;

std::string base64_encode(const void* data, size_t size) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const uint32_t v = uint32_t(p[i]) << 16 | (i + 1 < size ? uint32_t(p[i + 1]) << 8 : 0) | (i + 2 < size ? p[i + 2] : 0);
    out += k[v >> 18 & 63];
    out += k[v >> 12 & 63];
    out += i + 1 < size ? k[v >> 6 & 63] : '=';
    out += i + 2 < size ? k[v & 63] : '=';
  }
  return out;
}

std::string base64_decode(const std::string& s) {
  auto val = [](char c) -> int {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    if (c == '+') return 62;
    if (c == '/') return 63;
    return -1;
  };
  std::string out;
  uint32_t acc = 0;
  int bits = 0;
  size_t pad = 0;
  for (char c : s) {
    if (c == '=') {
      ++pad;
      continue;
    }
    const int v = val(c);
    if (v < 0 || pad) throw Error("base64: invalid character in the data");
    acc = acc << 6 | uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += char(acc >> bits & 0xff);
    }
  }
  if (pad > 2) throw Error("base64: too much padding");
  return out;
}

namespace {

// The smallest canvas the studio draws, px: below it the 3D view and the
// curve handles have nothing to show.
constexpr int kMinStudioSidePx = 32;

// A user-correctable problem with a request: 400 with the message.
struct BadRequest : Error {
  using Error::Error;
};


// A request body as JSON: discarded when it is not JSON, a 400 naming the
// guard when it nests too deep or repeats a key (files.hpp's checked parse).
nlohmann::json body_json(const std::string& body) {
  try {
    return parse_json_checked(body, "request body");
  } catch (const nlohmann::json::exception&) {
    return nlohmann::json(nlohmann::json::value_t::discarded);
  } catch (const Error& e) {
    throw BadRequest(e.what());
  }
}


// Text from a request, fit for a one-line message: control bytes (a NUL
// would cut the message short) and non-ASCII shown as \xNN, at most 80 bytes.
std::string printable(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size() && i < 80; ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else {
      char b[8];
      std::snprintf(b, sizeof b, "\\x%02x", c);
      out += b;
    }
  }
  return s.size() > 80 ? out + "..." : out;
}

// Export names: a plain file name inside the output folder, nothing else
// (no '/', no '..', no hidden files).
void check_name(const std::string& name) {
  static const std::regex ok("[A-Za-z0-9][A-Za-z0-9_-]{0,63}");
  if (!std::regex_match(name, ok))
    throw BadRequest("name '" + printable(name) + "': use 1–64 letters, digits, '-' and '_' (a file name in the output folder)");
}

// The host part of a Host header ("127.0.0.1:8080", "[::1]:8080",
// "localhost") and its port (-1 when absent).
std::pair<std::string, int> split_host(const std::string& h) {
  std::string name = h, port;
  if (!h.empty() && h[0] == '[') {
    const size_t close = h.find(']');
    if (close == std::string::npos) return {"", -1};
    name = h.substr(1, close - 1);
    if (close + 1 < h.size()) {
      if (h[close + 1] != ':') return {"", -1};
      port = h.substr(close + 2);
    }
  } else if (const size_t colon = h.rfind(':'); colon != std::string::npos) {
    name = h.substr(0, colon);
    port = h.substr(colon + 1);
  }
  if (port.empty()) return {name, -1};
  if (port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos) return {"", -1};
  return {name, std::stoi(port)};
}

bool is_ip_literal(const std::string& name) {
  unsigned char buf[16];
  return ::inet_pton(AF_INET, name.c_str(), buf) == 1 || ::inet_pton(AF_INET6, name.c_str(), buf) == 1;
}

std::string lower(std::string s) {
  for (auto& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Content types of the page's files, by extension.
std::string content_type_of(const fs::path& p) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"},
      {".json", "application/json"}, {".png", "image/png"}, {".svg", "image/svg+xml"},
      {".ico", "image/x-icon"}, {".txt", "text/plain; charset=utf-8"}};
  const auto it = types.find(lower(p.extension().string()));
  return it == types.end() ? "application/octet-stream" : it->second;
}

}  // namespace

// Inference requests holding a decoded sketch at once (each ~70 MB at
// 4096²: label maps waiting for the compute lock; 64 request threads could
// hold 4.5 GB). Two: one computing, one decoded and ready; the others wait
// before decoding, and are answered 409 without decoding when superseded.
// (Layer and export requests decode under the compute lock, one at a time.)
constexpr int kStudioDecodeSlots = 2;
// The loopback listener's backlog: the front door's relays at once (256,
// FrontDoorLimits::max_relays) and room to spare, as its own listener has.
constexpr int kBackendBacklog = 1024;
// Islands one Variations request draws by default, and at most (each is an
// inference at the model's side: ~0.3 s on 2 cores).
constexpr int kStudioVariations = 4, kStudioMaxVariations = 8;

// A counting semaphore (C++17 has none): take() blocks while every slot is
// held; the Slot returned gives it back when it goes out of scope. Outside the
// anonymous namespace: a member of Impl.
class DecodeSlots {
 public:
  explicit DecodeSlots(int n) : free_(n) {}
  class Slot {
   public:
    explicit Slot(DecodeSlots& s) : s_(s) {}
    Slot(const Slot&) = delete;
    Slot& operator=(const Slot&) = delete;
    ~Slot() {
      {
        std::lock_guard<std::mutex> lock(s_.m_);
        ++s_.free_;
      }
      s_.cv_.notify_one();
    }

   private:
    DecodeSlots& s_;
  };
  Slot take() {
    std::unique_lock<std::mutex> lock(m_);
    cv_.wait(lock, [&] { return free_ > 0; });
    --free_;
    return Slot(*this);
  }

 private:
  std::mutex m_;
  std::condition_variable cv_;
  int free_;
};


struct StudioServer::Impl {
  StudioOptions o;
  model::GeneratorFile gen;
  infer::InferOptions io;
  httplib::Server svr;
  std::atomic<int> backend_fd{-1};  // the library's listening socket (set_socket_options)
  std::mutex compute;          // one inference / generation at a time
  DecodeSlots decodes{kStudioDecodeSlots};  // sketches decoded at once (outside `compute`)
  std::atomic<uint64_t> latest{0};
  int port = -1;               // the bound public port (Host checks)
  std::unique_ptr<FrontDoor> front;  // owns the public port (front_door.hpp)
  int backend_port = -1;       // the library's loopback port behind it
  // The page: URL path -> file, listed once at start. Regular files only:
  // symbolic links in the folder are never followed, and nothing outside
  // this list is ever served.
  std::map<std::string, fs::path> assets;

  void list_assets() {
    if (o.assets_dir.empty()) return;
    std::error_code ec;
    if (!fs::is_directory(o.assets_dir, ec))
      throw Error("studio: the page's folder " + o.assets_dir.string() + " is missing (rebuild: bash scripts/build.sh)");
    for (auto it = fs::recursive_directory_iterator(o.assets_dir, fs::directory_options::none, ec);
         it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (ec) break;
      const fs::file_status st = it->symlink_status(ec);
      if (!fs::is_regular_file(st)) continue;  // links, folders (not descended into when links), devices
      const std::string rel = fs::relative(it->path(), o.assets_dir, ec).generic_string();
      if (!ec && !rel.empty()) assets["/" + rel] = it->path();
    }
  }

  // Requests from the page itself, and nothing else, may reach the API:
  //  - Host must name this server (an IP literal, localhost or --host, with
  //    the bound port): a DNS-rebinding page's Host is its own domain name.
  //  - State-changing methods must not come from another origin (CSRF): a
  //    browser sends Origin with every cross-origin POST, even text/plain
  //    "simple" ones, and Sec-Fetch-Site where it knows it.
  //  - Bodies have a Content-Length within the limit: chunked bodies would be
  //    read without bound by the HTTP library, so they are refused up front.
  //  - Form encodings are refused (the API takes JSON or an image); the HTTP
  //    library would parse them into parameters under its own 8 KiB limit.
  // Returns the status and message of a refusal, or status 0.
  std::pair<int, std::string> refusal(const httplib::Request& req) const {
    if (!req.has_header("Host")) return {400, "no Host header"};
    const std::string host = req.get_header_value("Host");
    const auto [name, p] = split_host(host);
    const std::string lname = lower(name);
    const bool name_ok = !lname.empty() && (lname == lower(o.host) || lname == "localhost" || is_ip_literal(lname));
    if (!name_ok || p != port)
      return {403, "Host '" + printable(host) + "' is not this studio (" + o.host + ":" + std::to_string(port) +
                       "); open the page at http://127.0.0.1:" + std::to_string(port) + "/"};
    // RFC 7230 §3.3.3: differing Content-Length values are an error (behind a
    // proxy, the classic request-smuggling shape).
    for (size_t i = 1; i < req.get_header_value_count("Content-Length"); ++i)
      if (req.get_header_value("Content-Length", i) != req.get_header_value("Content-Length", 0))
        return {400, "two different Content-Length headers; send one"};
    const bool safe = req.method == "GET" || req.method == "HEAD" || req.method == "OPTIONS";
    if (safe) return {0, ""};
    if (req.has_header("Origin") && req.get_header_value("Origin") != "http://" + host)
      return {403, "cross-origin request from '" + printable(req.get_header_value("Origin")) +
                       "' refused: only the studio's own page may change files"};
    if (req.has_header("Sec-Fetch-Site")) {
      const std::string site = req.get_header_value("Sec-Fetch-Site");
      if (site != "same-origin" && site != "none")
        return {403, "cross-site request (Sec-Fetch-Site: " + printable(site) + ") refused"};
    }
    const std::string te = lower(req.get_header_value("Transfer-Encoding"));
    if (!te.empty() && te != "identity")
      return {411, "Transfer-Encoding '" + printable(te) + "' refused: send the body with a Content-Length (at most " +
                       std::to_string(o.max_body_bytes) + " bytes)"};
    const std::string ct = lower(req.get_header_value("Content-Type"));
    if (ct.rfind("application/x-www-form-urlencoded", 0) == 0 || ct.rfind("multipart/form-data", 0) == 0)
      return {415, "Content-Type '" + printable(ct) + "' refused: send JSON (application/json) or an image"};
    return {0, ""};
  }

  // Refuses a sketch from what its request declares (an empty body, a side
  // read from the image header, raw dimensions), before anything is decoded
  // and before the request takes a ticket: a request that can only fail
  // neither supersedes the painter's last good one nor is answered
  // "superseded" instead of its own error (a 409 for a 30000² PNG when eight
  // arrived at once).
  void refuse_by_header(const httplib::Request& req, bool raw) const {
    if (raw) {
      raw_dims(req);
      return;
    }
    if (req.body.empty()) throw BadRequest("empty body: send the sketch as a PNG or JPEG image");
    const cv::Size d = declared_image_size(req.body);
    if (d.width > o.max_side || d.height > o.max_side)
      throw BadRequest("the sketch: " + std::to_string(d.width) + "×" + std::to_string(d.height) + " pixels; at most " +
                       std::to_string(o.max_side) + " a side here (scale the image down first)");
  }

  // Decodes a sketch image from request bytes, bounded in size.
  DecodedSketch sketch_of(const std::string& bytes) {
    if (bytes.empty()) throw BadRequest("empty body: send the sketch as a PNG or JPEG image");
    cv::Mat img;
    try {
      // The side is checked from the header before decoding: a small PNG
      // may declare 30000² pixels (docs/STUDIO.md).
      img = decode_image(bytes, "the sketch", cv::IMREAD_UNCHANGED, o.max_side);
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
    if (img.cols > o.max_side || img.rows > o.max_side)
      throw BadRequest("sketch is " + std::to_string(img.cols) + "×" + std::to_string(img.rows) + "; at most " +
                       std::to_string(o.max_side) + " pixels a side");
    try {
      return decode_sketch(img, "sketch");
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
  }

  // A raw RGBA sketch's ?w= and ?h=, checked against the body's size.
  cv::Size raw_dims(const httplib::Request& req) const {
    auto dim = [&](const char* k) {
      const std::string v = req.get_param_value(k);
      if (v.empty() || v.size() > 5 || v.find_first_not_of("0123456789") != std::string::npos)
        throw BadRequest(std::string("raw RGBA sketch: ?") + k + "= must be a whole number of pixels in 16.." +
                         std::to_string(o.max_side));
      const int n = std::stoi(v);
      if (n < 16 || n > o.max_side)
        throw BadRequest(std::string("raw RGBA sketch: ") + k + " = " + v + "; use 16.." + std::to_string(o.max_side));
      return n;
    };
    const int w = dim("w"), h = dim("h");
    if (req.body.size() != size_t(w) * size_t(h) * 4)
      throw BadRequest("raw RGBA sketch: " + std::to_string(req.body.size()) + " bytes for " + std::to_string(w) + "×" +
                       std::to_string(h) + " pixels; send w·h·4 bytes");
    return {w, h};
  }
  // A sketch sent as the canvas's raw pixels (RGBA, row 0 on top, w·h·4
  // bytes): the page skips PNG encoding, which cost it up to a second per
  // stroke on the main thread (docs/STUDIO.md).
  DecodedSketch sketch_of_rgba(const httplib::Request& req) {
    const cv::Size d = raw_dims(req);
    const cv::Mat rgba(d.height, d.width, CV_8UC4, const_cast<char*>(req.body.data()));
    // Alpha kept: a transparent pixel is open ocean, as in a PNG sketch and
    // the CLI (decode_sketch), whatever colour it carries.
    cv::Mat bgra;
    cv::cvtColor(rgba, bgra, cv::COLOR_RGBA2BGRA);
    try {
      return decode_sketch(bgra, "sketch");
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
  }

  // The canvas side a request may ask for, kMinStudioSidePx..max_side.
  void check_side(int64_t n) const {
    if (n < kMinStudioSidePx || n > o.max_side)
      throw BadRequest("size must be in " + std::to_string(kMinStudioSidePx) + ".." + std::to_string(o.max_side));
  }

  // ?seed=N (infer --seed: which island of the painting): digits only, below 2^64.
  static uint64_t seed_param(const std::string& v) {
    const std::string what = "seed must be a whole number in [0, 18446744073709551615] (infer --seed)";
    if (v.empty() || v.size() > 20 || v.find_first_not_of("0123456789") != std::string::npos) throw BadRequest(what);
    errno = 0;
    const unsigned long long n = std::strtoull(v.c_str(), nullptr, 10);
    if (errno == ERANGE) throw BadRequest(what);
    return uint64_t(n);
  }
  infer::InferOptions with_seed(uint64_t seed) const {
    infer::InferOptions o = io;
    o.seed = seed;
    return o;
  }
  // A plain decimal number in [lo, hi] (no sign, no exponent), or the line `what`.
  static double number_param(const std::string& v, double lo, double hi, const std::string& what) {
    if (v.empty() || v.size() > 12 || v.find_first_not_of("0123456789.") != std::string::npos) throw BadRequest(what);
    char* end = nullptr;
    const double t = std::strtod(v.c_str(), &end);
    if (end != v.c_str() + v.size() || !(t >= lo && t <= hi)) throw BadRequest(what);
    return t;
  }
  // body[key], a number in [lo, hi], or `otherwise` when absent.
  static double json_number(const json& body, const char* key, double lo, double hi, const std::string& what,
                            double otherwise) {
    if (!body.contains(key)) return otherwise;
    if (!body[key].is_number() || !(body[key].get<double>() >= lo && body[key].get<double>() <= hi)) throw BadRequest(what);
    return body[key].get<double>();
  }
  // ?age_myr=T (infer --age-myr: the painting's subsidence and the erosion
  // maturity of that age, reefgen/age.hpp): a number in [0, 60].
  static constexpr const char* kAgeWhat = "age_myr must be a number of millions of years in [0, 60] (infer --age-myr)";
  // ?maturity=M (infer --maturity: the erosion maturity alone; the painting
  // keeps its subsidence): a number in [0.05, 20].
  static constexpr const char* kMaturityWhat = "maturity must be a number in [0.05, 20] (infer --maturity)";
  // The island a request asks for: ?seed=, ?age_myr= and ?maturity=.
  infer::InferOptions island_options(const httplib::Request& req) const {
    infer::InferOptions o = with_seed(req.has_param("seed") ? seed_param(req.get_param_value("seed")) : 0);
    if (req.has_param("age_myr")) o.age_myr = number_param(req.get_param_value("age_myr"), 0, kMaxAgeMyr, kAgeWhat);
    if (req.has_param("maturity"))
      o.maturity = number_param(req.get_param_value("maturity"), kMinMaturity, kMaxMaturity, kMaturityWhat);
    return o;
  }

  // ?size=N: digits only, in range (atoi wrapped 4294967328 to 32).
  int size_param(const std::string& v) const {
    const std::string range =
        "size must be a whole number of pixels in " + std::to_string(kMinStudioSidePx) + ".." + std::to_string(o.max_side);
    if (v.empty() || v.size() > 6 || v.find_first_not_of("0123456789") != std::string::npos) throw BadRequest(range);
    const int n = std::stoi(v);
    if (n < kMinStudioSidePx || n > o.max_side) throw BadRequest(range);
    return n;
  }

  // keep_uneroded: also the heights before erosion (the layers' wear and deposit).
  procgen::IslandFields island_of(const json& spec_json, int size, procgen::IslandSpec* spec_out,
                                  bool keep_uneroded = false) {
    check_side(size);
    procgen::IslandSpec spec;
    try {
      spec = procgen::spec_from_json(spec_json, "spec");
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
    procgen::RenderOptions ro;
    ro.size_px = size;
    ro.keep_uneroded = keep_uneroded;
    if (spec_out) *spec_out = spec;
    return procgen::generate(spec, ro);
  }

  // What an export or a layer view is made from: the page's source (a
  // painted sketch, or a spec and a size) computed again, deterministically.
  struct Source {
    cv::Mat1f height_m;
    cv::Mat1f before_m;  // heights before erosion (the layers' wear and deposit), when known
    cv::Mat1f rain_mm_yr;  // the rain the erosion read (curves mode with wind), else empty
    cv::Mat1b region;    // region ids at the heights' size
    cv::Mat3b label;     // the HSV label map
    json spec_json;      // curves mode: the spec as run
    double metres_per_px = 0;
  };
  Source source_of(const json& body, bool keep_uneroded) {
    if (body.is_discarded() || !body.is_object())
      throw BadRequest("the body must be JSON: {\"sketch_png\": base64} or {\"spec\": {...}, \"size\": N}");
    const bool from_spec = body.contains("spec");
    if (!from_spec && !body.contains("sketch_png")) throw BadRequest("the body needs sketch_png or spec");
    Source src;
    std::lock_guard<std::mutex> lock(compute);
    if (from_spec) {
      procgen::IslandSpec sp;
      if (body.contains("size") && !body["size"].is_number_integer())
        throw BadRequest("size must be a whole number of pixels in " + std::to_string(kMinStudioSidePx) + ".." +
                         std::to_string(o.max_side));
      // Range-checked as int64 before narrowing: 4294967328 must not become 32.
      const int64_t size = body.contains("size") ? body["size"].get<int64_t>() : 256;
      check_side(size);
      const procgen::IslandFields f = island_of(body["spec"], int(size), &sp, keep_uneroded);
      src = {f.height_m, f.uneroded_m, f.rain_mm_yr, f.label, encode_labels(f.label, sp.subsidence), {},
             sp.world_size_m / f.height_m.cols};
      procgen::to_json(src.spec_json, sp);
      return src;
    }
    if (!body["sketch_png"].is_string()) throw BadRequest("sketch_png must be a string: the sketch PNG in base64");
    std::string png;
    try {
      png = base64_decode(body["sketch_png"].get<std::string>());
    } catch (const Error& e) {
      throw BadRequest(std::string("sketch_png: ") + e.what());
    }
    uint64_t seed = 0;
    if (body.contains("seed")) {
      if (!body["seed"].is_number_unsigned()) throw BadRequest("seed must be a whole number in [0, 2^64) (infer --seed)");
      seed = body["seed"].get<uint64_t>();
    }
    infer::InferOptions options = with_seed(seed);
    options.age_myr = json_number(body, "age_myr", 0, kMaxAgeMyr, kAgeWhat, options.age_myr);
    options.maturity = json_number(body, "maturity", kMinMaturity, kMaxMaturity, kMaturityWhat, options.maturity);
    const DecodedSketch s = sketch_of(png);
    src.height_m = infer::infer_heights(gen, {s}, options)[0];
    src.label = encode_labels(s.label, s.subsidence);
    cv::resize(s.label, src.region, src.height_m.size(), 0, 0, cv::INTER_NEAREST);
    src.metres_per_px = kCanvasWorldSizeM / src.height_m.cols;
    return src;
  }

  // {"ocean_floor_m": D} in an export's body: the CLI's --ocean-floor-m
  // (terrain/ocean_floor.hpp), the open ocean's flank continued towards D.
  static void deepen_if_asked(const json& body, Source& src) {
    if (!body.contains("ocean_floor_m") || body["ocean_floor_m"].is_null()) return;
    const json& d = body["ocean_floor_m"];
    if (!d.is_number() ||
        !(d.get<double>() >= terrain::kDeepestOceanFloorM && d.get<double>() <= terrain::kShallowestOceanFloorM))
      throw BadRequest("ocean_floor_m must be a depth in metres in [-11000, -60], e.g. -2000 (or left out)");
    terrain::deepen_flank(src.height_m, d.get<double>(), src.metres_per_px, src.region);
    if (!src.before_m.empty()) terrain::deepen_flank(src.before_m, d.get<double>(), src.metres_per_px, src.region);
  }

  // The bundle of `e` (layers from the regions, the erosion when known) staged
  // into OUT/NAME.<engine>/ and sent as NAME.<engine>.zip holding exactly
  // this export's files (an earlier, larger export's tiles may still be in
  // the folder).
  // Nothing is written outside --out (docs/STUDIO.md): a bundle folder that
  // is a link (or resolves elsewhere) would carry the export out of it.
  void refuse_link_out(const fs::path& folder) const {
    std::error_code ec;
    const bool link = fs::symlink_status(folder, ec).type() == fs::file_type::symlink;
    const fs::path real = fs::weakly_canonical(folder, ec), root = fs::weakly_canonical(o.out_dir, ec);
    const fs::path rel = real.lexically_relative(root);
    if (link || ec || rel.empty() || *rel.begin() == "..")
      throw BadRequest(folder.filename().string() + " in the studio's folder is a link elsewhere; nothing is written "
                       "outside --out: remove the link or choose another name");
  }

  void send_bundle(httplib::Response& res, engines::Engine e, const std::string& name, const Source& src) {
    const terrain::Layers L = terrain::compute_layers(src.height_m, src.before_m, src.region, src.metres_per_px);
    std::error_code ec;
    fs::create_directories(o.out_dir, ec);
    ensure_writable_dir(o.out_dir);
    const std::string folder = name + "." + engines::to_string(e);
    refuse_link_out(o.out_dir / folder);
    StagedOutputs staged;
    engines::stage_bundle(staged, o.out_dir / folder, name, e, {src.height_m, &L, src.metres_per_px, {}});
    staged.commit();
    std::vector<std::pair<std::string, std::string>> files;
    for (const fs::path& f : staged.finals()) files.emplace_back(folder + "/" + f.filename().string(), read_text(f, size_t(4) << 30));
    const std::string zip = zip_stored(files);
    res.set_header("Content-Disposition", "attachment; filename=\"" + folder + ".zip\"");
    res.set_header("X-Reefgen-Path", fs::absolute(o.out_dir / folder).string());
    // The size the engine wanted instead (the bundle's README says it too).
    if (const std::string note = engines::size_note(e, src.height_m.cols); !note.empty())
      res.set_header("X-Reefgen-Note", note.substr(note.find(": ") + 2));
    res.set_content(zip, "application/zip");
  }

  json heights_meta(const cv::Mat1f& h, double ms) {
    double lo, hi;
    cv::minMaxLoc(h, &lo, &hi);
    return {{"size", h.cols},  {"min_m", lo},         {"max_m", hi}, {"lo_m", gen.range.lo_m},
            {"hi_m", gen.range.hi_m}, {"metres_per_px", kCanvasWorldSizeM / h.cols}, {"ms", ms}};
  }

  // The heights answer: [uint32 LE n][n bytes of JSON, space-padded so the
  // floats start 4-byte aligned][size² float32 LE heights in metres, row 0 =
  // north]. Binary, not base64 in JSON: a quarter smaller, no decoding, and
  // the HTTP library leaves octet-streams uncompressed (its brotli pass on a
  // JSON answer cost ~1 s per stroke).
  // [uint32 n][n bytes JSON][heights], little-endian (x86-64). Heights are
  // float32, or with ?enc=u16 uint16 steps of `u16_step_m` above `u16_lo_m` (half
  // the bytes: at 1024² the page's view gets 2 MB instead of 4; 1 cm steps
  // for a 650 m range are below anything the view can show, and exports are
  // recomputed from the sketch, never from these numbers).
  static void send_heights(httplib::Response& res, const cv::Mat1f& h, json meta, bool u16) {
    CV_Assert(h.isContinuous());
    double lo = 0, hi = 0;
    cv::minMaxLoc(h, &lo, &hi);
    const double step = hi > lo ? (hi - lo) / 65535.0 : 1.0;
    if (u16) {
      meta["encoding"] = "u16";
      meta["u16_lo_m"] = lo;
      meta["u16_step_m"] = step;
    }
    std::string head = meta.dump(-1, ' ', false, json::error_handler_t::replace);
    while ((4 + head.size()) % 4) head += ' ';
    const size_t bytes = h.total() * (u16 ? sizeof(uint16_t) : sizeof(float));
    std::string body(4 + head.size() + bytes, '\0');
    const uint32_t n = uint32_t(head.size());
    for (int i = 0; i < 4; ++i) body[size_t(i)] = char(n >> (8 * i) & 0xff);
    std::memcpy(&body[4], head.data(), head.size());
    if (u16) {
      cv::Mat1w q(h.rows, h.cols, reinterpret_cast<uint16_t*>(&body[4 + head.size()]));
      h.convertTo(q, CV_16U, 1.0 / step, -lo / step);  // rounds and saturates
    } else {
      std::memcpy(&body[4 + head.size()], h.ptr<float>(), bytes);
    }
    res.set_content(body, "application/octet-stream");
  }

  // Runs f under the compute lock unless a newer request came in meanwhile
  // (the ticket: ++latest when the request arrived).
  template <class F>
  void latest_wins(httplib::Response& res, uint64_t ticket, F&& f) {
    std::lock_guard<std::mutex> lock(compute);
    if (superseded(res, ticket)) return;
    f();
  }
  template <class F>
  void latest_wins(httplib::Response& res, F&& f) {
    latest_wins(res, ++latest, std::forward<F>(f));
  }
  // Answers 409 when a newer request came in after `ticket`.
  bool superseded(httplib::Response& res, uint64_t ticket) {
    if (ticket == latest.load()) return false;
    res.status = 409;
    res.set_content(json{{"error", "superseded by a newer request"}}.dump(), "application/json");
    return true;
  }

  static void fail(httplib::Response& res, int status, const std::string& msg) {
    res.status = status;
    // Messages may quote request bytes (names, image chunks): invalid UTF-8
    // is replaced, never an exception from inside an error path (that was a
    // 500, found by fuzz_studio).
    res.set_content(json{{"error", msg}}.dump(-1, ' ', false, json::error_handler_t::replace), "application/json");
  }

  // Wraps a handler: BadRequest -> 400, Interrupted -> 503, any other
  // exception -> 500; one line each.
  template <class H>
  httplib::Server::Handler guarded(H h) {
    return [h](const httplib::Request& req, httplib::Response& res) {
      try {
        h(req, res);
      } catch (const BadRequest& e) {
        fail(res, 400, e.what());
      } catch (const Interrupted&) {  // the studio is stopping (Ctrl-C): the work stopped between its steps
        fail(res, 503, "the studio is stopping; send the request again once it runs");
      } catch (const Error& e) {  // reefgen's errors are the user's to fix by definition (bad spec, bad image)
        std::string m = e.what();
        fail(res, 400, m.substr(0, m.find('\n')));
      } catch (const std::exception& e) {
        std::string m = e.what();
        m = m.substr(0, m.find('\n'));
        fail(res, 500, m);
      }
    };
  }

  // A member answering one route, behind guarded()'s one-line errors.
  using Answer = void (Impl::*)(const httplib::Request&, httplib::Response&);
  httplib::Server::Handler handler(Answer a) {
    return guarded([this, a](const httplib::Request& req, httplib::Response& res) { (this->*a)(req, res); });
  }

  void answer_info(const httplib::Request&, httplib::Response& res) {
    const auto& u = gen.g->options();
    res.set_content(json{{"version", kVersion},
                         {"model", {{"path", fs::absolute(o.model).string()}, {"size_px", gen.size_px},
                                    {"ngf", u.ngf}, {"upsample", model::to_string(u.upsample)},
                                    {"train_step", gen.train_step}, {"lo_m", gen.range.lo_m}, {"hi_m", gen.range.hi_m}}},
                         {"precision", infer::to_string(infer::resolve(io, gen))},
                         {"engine", infer::to_string(infer::resolve_engine(io))},
                         {"max_side", o.max_side},
                         {"max_body_bytes", o.max_body_bytes},
                         {"out_dir", fs::absolute(o.out_dir).string()}}
                        .dump(-1, ' ', false, json::error_handler_t::replace),
                    "application/json");
  }

  void answer_presets(const httplib::Request&, httplib::Response& res) {
    json j = json::object();
    for (const auto& [name, text] : o.presets) j[name] = json::parse(text);
    res.set_content(j.dump(), "application/json");
  }

  void answer_defaults(const httplib::Request&, httplib::Response& res) {
    json j;
    procgen::to_json(j, procgen::IslandSpec{});  // the paper's profile and resistance curves among them
    res.set_content(j.dump(), "application/json");
  }

  void answer_infer(const httplib::Request& req, httplib::Response& res) {
    const bool raw = lower(req.get_header_value("Content-Type")).rfind("application/x-reefgen-rgba", 0) == 0;
    refuse_by_header(req, raw);
    const uint64_t ticket = ++latest;
    // The slot is held until the answer is sent: a decoded sketch waiting for
    // the compute lock holds its label maps (~70 MB at 4096²), and 32
    // requests waiting held 3.8 GB. A request superseded while it waited for
    // a slot is answered without decoding.
    const infer::InferOptions options = island_options(req);
    const auto slot = decodes.take();
    if (superseded(res, ticket)) return;
    const DecodedSketch s = raw ? sketch_of_rgba(req) : sketch_of(req.body);
    latest_wins(res, ticket, [&] {
      const auto t0 = std::chrono::steady_clock::now();
      const cv::Mat1f h = infer::infer_heights(gen, {s}, options)[0];
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      send_heights(res, h, heights_meta(h, ms), req.get_param_value("enc") == "u16");
    });
  }

  // Variations of the painting (infer --variations): n islands from seed on,
  // each as a hill-shaded picture with its seed, for the artist to pick one.
  void answer_variations(const httplib::Request& req, httplib::Response& res) {
    const bool raw = lower(req.get_header_value("Content-Type")).rfind("application/x-reefgen-rgba", 0) == 0;
    refuse_by_header(req, raw);
    const uint64_t ticket = ++latest;
    const infer::InferOptions options = island_options(req);
    const uint64_t seed = options.seed;
    int n = kStudioVariations;
    if (req.has_param("n")) {
      const std::string t = req.get_param_value("n");
      if (t.empty() || t.size() > 2 || t.find_first_not_of("0123456789") != std::string::npos || std::stoi(t) < 2 ||
          std::stoi(t) > kStudioMaxVariations)
        throw BadRequest("n must be a whole number from 2 to " + std::to_string(kStudioMaxVariations));
      n = std::stoi(t);
    }
    const auto slot = decodes.take();
    if (superseded(res, ticket)) return;
    const DecodedSketch s = raw ? sketch_of_rgba(req) : sketch_of(req.body);
    latest_wins(res, ticket, [&] {
      const std::vector<cv::Mat1f> hs = infer::infer_variations(gen, s, options, n, default_threads());
      json j = {{"seeds", json::array()}, {"previews", json::array()}};
      for (int k = 0; k < n; ++k) {
        const std::string png = encode_png8(render_preview(hs[size_t(k)]), 1);
        j["seeds"].push_back(seed + uint64_t(k));
        j["previews"].push_back(base64_encode(png.data(), png.size()));
      }
      res.set_content(j.dump(), "application/json");
    });
  }

  void answer_generate(const httplib::Request& req, httplib::Response& res) {
    const json spec = body_json(req.body);
    if (spec.is_discarded()) throw BadRequest("the body is not valid JSON: send an island spec (docs/SPEC.md)");
    const int size = req.has_param("size") ? size_param(req.get_param_value("size")) : 256;
    latest_wins(res, [&] {
      const auto t0 = std::chrono::steady_clock::now();
      procgen::IslandSpec sp;
      const procgen::IslandFields f = island_of(spec, size, &sp);
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      json j = heights_meta(f.height_m, ms);
      std::vector<uchar> png;
      cv::imencode(".png", encode_labels(f.label, sp.subsidence), png);
      j["label_png"] = base64_encode(png.data(), png.size());
      j["metres_per_px"] = sp.world_size_m / f.height_m.cols;
      send_heights(res, f.height_m, j, req.get_param_value("enc") == "u16");
    });
  }

  // A layer as a picture for the 2D view and the 3D view's texture
  // (docs/STUDIO.md): materials (hill-shaded base colours), flow, or the
  // rain the erosion read (curves mode, where the spec has wind strokes).
  void answer_layers(const httplib::Request& req, httplib::Response& res) {
    const std::string view = req.get_param_value("view");
    if (view != "materials" && view != "flow" && view != "rain")
      throw BadRequest("view '" + view + "': use materials, flow or rain");
    const Source src = source_of(body_json(req.body), true);
    if (view == "rain" && src.rain_mm_yr.empty())
      throw BadRequest("view rain: this island has no rain from a wind (draw wind strokes in curves mode; a painted sketch has none)");
    const terrain::Layers L = terrain::compute_layers(src.height_m, src.before_m, src.region, src.metres_per_px);
    const cv::Mat3b picture = view == "materials" ? terrain::material_colour_map(L)
                              : view == "flow"    ? terrain::flow_colour_map(L, src.height_m, src.metres_per_px)
                                                  : terrain::rain_colour_map(L, src.height_m, src.rain_mm_yr);
    res.set_content(encode_png8(picture, 1), "image/png");
  }

  // One file per format beside the CLI's (the same writers), or a bundle.
  static const std::map<std::string, std::string>& export_suffixes() {
    static const std::map<std::string, std::string> ext = {{"exr", ".height.exr"}, {"png16", ".height.png"},
                                                           {"r16", ".r16"},        {"glb", ".glb"},
                                                           {"obj", ".obj"},        {"sketch", ".sketch.png"},
                                                           {"spec", ".spec.json"}};
    return ext;
  }

  void answer_export(const httplib::Request& req, httplib::Response& res) {
    const std::string format = req.get_param_value("format"), name = req.get_param_value("name");
    check_name(name);
    // Engine bundles (docs/ENGINES.md): the folder NAME.<engine>/ in the
    // output folder, sent as one stored ZIP.
    const bool bundle = engines::is_engine_name(format);
    if (!export_suffixes().count(format) && !bundle)
      throw BadRequest("format '" + format + "': use exr, png16, r16, glb, obj, sketch, spec, or a bundle: " +
                       engines::engine_names());
    const json body = body_json(req.body);
    if (format == "spec" && body.is_object() && !body.contains("spec"))
      throw BadRequest("format spec needs a spec (curves mode)");
    // The source again (deterministic), then the CLI's writer for the format.
    Source src = source_of(body, bundle);
    deepen_if_asked(body, src);
    std::error_code ec;
    fs::create_directories(o.out_dir, ec);
    ensure_writable_dir(o.out_dir);
    if (bundle) send_bundle(res, engines::engine_from_string(format), name, src);
    else send_file(res, format, name, src);
  }

  // OUT/NAME.<suffix> written with the CLI's writer for `format` and sent.
  void send_file(httplib::Response& res, const std::string& format, const std::string& name, const Source& src) {
    const cv::Mat1f& h = src.height_m;
    const fs::path path = o.out_dir / (name + export_suffixes().at(format));
    // 16-bit files span the field's own range (a 608 m preset peak was
    // clipped at the model's 560 m); the range and each engine's import
    // numbers go to NAME.<format>.import.json beside the file (one per
    // format: an R16 and a PNG16 of one name used to share one note).
    cv::Mat1f exported = h;
    if (format == "r16") {
      // Unity's terrains are 2^n + 1 samples a side: the rule and the
      // corner-keeping resampling of `--for unity` (docs/ENGINES.md).
      exported = engines::resample_corners(h, engines::unity_side(h.cols));
    }
    // r16: the resampled field's own spacing (the span is kept).
    const double export_mpp = src.metres_per_px * (h.cols - 1) / (exported.cols - 1);
    StagedOutputs staged;
    if (format == "sketch") {
      staged.write(path, [&](const fs::path& t) { write_png(t, src.label); });
    } else if (format == "spec") {
      staged.write(path, [&](const fs::path& t) { write_json_atomic(t, src.spec_json); });
    } else {
      HeightFiles hf;
      hf.exr = format == "exr";
      hf.png16 = format == "png16";
      hf.r16 = format == "r16";
      if (format == "glb" || format == "obj") hf.mesh = format;
      const json side = stage_height_files(staged, o.out_dir / name, exported, export_mpp, hf);
      if (side.contains(format)) {  // png16, r16: the range and each engine's numbers beside the file
        const std::string note = name + "." + format + ".import.json";
        staged.write(o.out_dir / note, [&](const fs::path& t) { write_json_atomic(t, side[format]["import"]); });
        res.set_header("X-Reefgen-Import-Note", note);
        res.set_header("X-Reefgen-Range-M", std::to_string(side[format]["lo_m"].get<double>()) + " " +
                                                std::to_string(side[format]["hi_m"].get<double>()));
      }
    }
    staged.commit();
    const std::string bytes = read_text(path);
    res.set_header("Content-Disposition", "attachment; filename=\"" + path.filename().string() + "\"");
    res.set_header("X-Reefgen-Path", fs::absolute(path).string());
    res.set_content(bytes, format == "spec" ? "application/json" : "application/octet-stream");
  }

  // The page's files (the API's routes above take precedence). The page may
  // be cached: three.js is 1.2 MB and the HTTP library compresses text on
  // every request.
  void answer_asset(const httplib::Request& req, httplib::Response& res) {
    const std::string path = req.path == "/" ? "/index.html" : req.path;
    const auto it = assets.find(path);
    std::error_code ec;
    if (it == assets.end() || !fs::is_regular_file(fs::symlink_status(it->second, ec))) {
      fail(res, 404, "not found: " + printable(req.path));
      return;
    }
    std::string bytes;
    try {
      bytes = read_text(it->second);
    } catch (const std::exception&) {
      fail(res, 404, "not found: " + printable(req.path));
      return;
    }
    res.set_header("Cache-Control", "max-age=600");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_content(bytes, content_type_of(it->second).c_str());
  }

  void routes() {
    svr.set_payload_max_length(o.max_body_bytes);
    // One listener per port: the library's default SO_REUSEPORT let a second
    // studio bind the same port and the kernel shared the requests.
    svr.set_socket_options([this](int sock) {
      int yes = 1;
      ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
      backend_fd = sock;
    });
    // Slow or stalled clients each hold a worker until their read times out:
    // enough workers that a few of them never starve the page.
    svr.new_task_queue = [] { return new httplib::ThreadPool(64); };
    svr.set_read_timeout(10, 0);
    // One request per connection: every request head then passes the front
    // door's deadline (front_door.hpp), a kept-alive one included.
    svr.set_keep_alive_max_count(1);
    svr.set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
      const auto [status, msg] = refusal(req);
      if (status == 0) return httplib::Server::HandlerResponse::Unhandled;
      fail(res, status, msg);
      res.set_header("Connection", "close");
      return httplib::Server::HandlerResponse::Handled;
    });
    // Errors raised inside the HTTP library (413 for a long body, 400 for a
    // malformed request) get the same one-line JSON as the API's own.
    svr.set_error_handler(httplib::Server::HandlerWithResponse(
        [max_body = o.max_body_bytes](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
      const std::string why = res.status == 413   ? "request body too large (at most " + std::to_string(max_body) + " bytes)"
                              : res.status == 404 ? "not found"
                              : res.status == 414 ? "request URI too long"
                                                  : "bad request (HTTP " + std::to_string(res.status) + ")";
      fail(res, res.status, why);
      return httplib::Server::HandlerResponse::Handled;
    }));
    list_assets();
    svr.Get("/api/info", handler(&Impl::answer_info));
    svr.Get("/api/presets", handler(&Impl::answer_presets));
    svr.Get("/api/defaults", handler(&Impl::answer_defaults));
    svr.Post("/api/infer", handler(&Impl::answer_infer));
    svr.Post("/api/variations", handler(&Impl::answer_variations));
    svr.Post("/api/generate", handler(&Impl::answer_generate));
    svr.Post("/api/layers", handler(&Impl::answer_layers));
    svr.Post("/api/export", handler(&Impl::answer_export));
    svr.Get(R"(/.*)", [this](const httplib::Request& req, httplib::Response& res) { answer_asset(req, res); });
    svr.set_exception_handler([](const httplib::Request&, httplib::Response& res, std::exception_ptr) {
      fail(res, 500, "internal error");
    });
  }
};

StudioServer::StudioServer(StudioOptions options) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.o = std::move(options);
  m.gen = model::load_generator(m.o.model);
  try {
    m.io.precision = infer::precision_from_string(m.o.precision);
    infer::resolve(m.io, m.gen);
  } catch (const Error& e) {
    throw Error(std::string("--precision: ") + e.what());
  }
  if (m.o.max_side < 64 || m.o.max_side > 4096) throw Error("studio: max_side must be in 64..4096");
  if (m.o.head_deadline_ms < 500 || m.o.head_deadline_ms > 60000)
    throw Error("studio: head_deadline_ms must be in 500..60000");
  // Checked now, not at the first export: an --out that is a file or
  // read-only would otherwise fail every export with an error.
  std::error_code ec;
  if (fs::exists(m.o.out_dir, ec) && !fs::is_directory(m.o.out_dir, ec))
    throw Error("studio: --out " + m.o.out_dir.string() + " is a file, not a folder; choose a folder for the exports");
  ensure_writable_dir(m.o.out_dir);
  m.routes();
}

StudioServer::~StudioServer() { stop(); }

int StudioServer::bind() {
  Impl& m = *impl_;
  // The public port is the front door's; the library listens on loopback
  // behind it and is reached only through it.
  FrontDoorLimits limits;
  limits.head_deadline = std::chrono::milliseconds(m.o.head_deadline_ms);
  m.front = std::make_unique<FrontDoor>(m.o.host, m.o.port, limits);
  m.backend_port = m.svr.bind_to_any_port("127.0.0.1");
  if (m.backend_port < 0) throw Error("studio: cannot listen on 127.0.0.1 (loopback) for the HTTP library");
  // Debian's libcpp-httplib is compiled with a listen backlog of 5: the front
  // door's relays overflowed it (200 concurrent requests, TCP retries of 1–15 s).
  // A second listen() on the bound socket sets the backlog (Linux listen(2)).
  if (m.backend_fd < 0 || ::listen(m.backend_fd, kBackendBacklog) != 0)
    throw Error("studio: cannot set the loopback listener's backlog: " + std::string(std::strerror(errno)));
  m.port = m.front->port();
  return m.port;
}

void StudioServer::serve() {
  Impl& m = *impl_;
  std::atomic<bool> library_done{false};
  std::thread library([&m, &library_done] {
    m.svr.listen_after_bind();
    library_done = true;
  });
  // The library must be running before anything may stop it: its stop()
  // does nothing before that, and the join below would wait for ever.
  while (!m.svr.is_running() && !library_done) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  try {
    m.front->run(m.backend_port);
  } catch (...) {
    m.svr.stop();
    library.join();
    throw;
  }
  m.svr.stop();
  library.join();
}

void StudioServer::stop() {
  if (!impl_) return;
  if (impl_->front) impl_->front->stop();
  if (impl_->svr.is_running()) impl_->svr.stop();
}

}  // namespace reefgen::studio
