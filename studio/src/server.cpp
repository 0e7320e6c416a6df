#include "reefgen/studio/server.hpp"

#include <httplib.h>

#include <chrono>
#include <cstring>
#include <cmath>
#include <mutex>
#include <regex>
#include <stdexcept>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/infer/export.hpp"
#include "reefgen/infer/infer.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/model/generator_file.hpp"
#include "reefgen/procgen/generator.hpp"
#include "reefgen/procgen/spec.hpp"
#include "reefgen/version.hpp"

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

// A user-correctable problem with a request: 400 with the message.
struct BadRequest : Error {
  using Error::Error;
};

// Export names: a plain file name inside the output folder, nothing else
// (no '/', no '..', no hidden files).
void check_name(const std::string& name) {
  static const std::regex ok("[A-Za-z0-9][A-Za-z0-9_-]{0,63}");
  if (!std::regex_match(name, ok))
    throw BadRequest("name '" + name + "': use 1–64 letters, digits, '-' and '_' (a file name in the output folder)");
}

}  // namespace

struct StudioServer::Impl {
  StudioOptions o;
  model::GeneratorFile gen;
  infer::InferOptions io;
  httplib::Server svr;
  std::mutex compute;          // one inference / generation at a time
  std::atomic<uint64_t> latest{0};

  // Decodes a sketch image from request bytes, bounded in size.
  DecodedSketch sketch_of(const std::string& bytes) {
    if (bytes.empty()) throw BadRequest("empty body: send the sketch as a PNG or JPEG image");
    cv::Mat img;
    try {
      img = cv::imdecode(std::vector<uchar>(bytes.begin(), bytes.end()), cv::IMREAD_UNCHANGED);
    } catch (const cv::Exception&) {
    }
    if (img.empty()) throw BadRequest("the body is not an image OpenCV can decode: send a PNG or JPEG");
    if (img.cols > o.max_side || img.rows > o.max_side)
      throw BadRequest("sketch is " + std::to_string(img.cols) + "×" + std::to_string(img.rows) + "; at most " +
                       std::to_string(o.max_side) + " pixels a side");
    try {
      return decode_sketch(img, "sketch");
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
  }

  procgen::IslandFields island_of(const json& spec_json, int size, procgen::IslandSpec* spec_out) {
    if (size < 32 || size > o.max_side) throw BadRequest("size must be in 32.." + std::to_string(o.max_side));
    procgen::IslandSpec spec;
    try {
      spec = procgen::spec_from_json(spec_json, "spec");
    } catch (const Error& e) {
      throw BadRequest(e.what());
    }
    procgen::RenderOptions ro;
    ro.size_px = size;
    if (spec_out) *spec_out = spec;
    return procgen::generate(spec, ro);
  }

  json heights_meta(const cv::Mat1f& h, double ms) {
    double lo, hi;
    cv::minMaxLoc(h, &lo, &hi);
    return {{"size", h.cols},  {"min_m", lo},         {"max_m", hi}, {"lo_m", gen.range.lo_m},
            {"hi_m", gen.range.hi_m}, {"metres_per_px", 6000.0 / h.cols}, {"ms", ms}};
  }

  // The heights answer: [uint32 LE n][n bytes of JSON, space-padded so the
  // floats start 4-byte aligned][size² float32 LE heights in metres, row 0 =
  // north]. Binary, not base64 in JSON: a quarter smaller, no decoding, and
  // the HTTP library leaves octet-streams uncompressed (its brotli pass on a
  // JSON answer cost ~1 s per stroke).
  static void send_heights(httplib::Response& res, const cv::Mat1f& h, json meta) {
    CV_Assert(h.isContinuous());
    std::string head = meta.dump();
    while ((4 + head.size()) % 4) head += ' ';
    std::string body(4 + head.size() + h.total() * sizeof(float), '\0');
    const uint32_t n = uint32_t(head.size());
    for (int i = 0; i < 4; ++i) body[size_t(i)] = char(n >> (8 * i) & 0xff);
    std::memcpy(&body[4], head.data(), head.size());
    std::memcpy(&body[4 + head.size()], h.ptr<float>(), h.total() * sizeof(float));  // x86-64: little-endian
    res.set_content(body, "application/octet-stream");
  }

  // Runs f under the compute lock unless a newer request came in meanwhile.
  template <class F>
  void latest_wins(httplib::Response& res, F&& f) {
    const uint64_t ticket = ++latest;
    std::lock_guard<std::mutex> lock(compute);
    if (ticket != latest.load()) {
      res.status = 409;
      res.set_content(json{{"error", "superseded by a newer request"}}.dump(), "application/json");
      return;
    }
    f();
  }

  static void fail(httplib::Response& res, int status, const std::string& msg) {
    res.status = status;
    res.set_content(json{{"error", msg}}.dump(), "application/json");
  }

  // Wraps a handler: BadRequest -> 400, any other exception -> 500; one line each.
  template <class H>
  httplib::Server::Handler guarded(H h) {
    return [h](const httplib::Request& req, httplib::Response& res) {
      try {
        h(req, res);
      } catch (const BadRequest& e) {
        fail(res, 400, e.what());
      } catch (const std::exception& e) {
        std::string m = e.what();
        m = m.substr(0, m.find('\n'));
        fail(res, 500, m);
      }
    };
  }

  void routes() {
    svr.set_payload_max_length(o.max_body_bytes);
    // The page's files may be cached: three.js is 1.2 MB and the HTTP library
    // compresses text on every request.
    if (!o.assets_dir.empty() && !svr.set_mount_point("/", o.assets_dir.string(), {{"Cache-Control", "max-age=600"}}))
      throw Error("studio: the page's folder " + o.assets_dir.string() + " is missing (rebuild: bash scripts/build.sh)");
    svr.Get("/api/info", guarded([this](const httplib::Request&, httplib::Response& res) {
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
                          .dump(),
                      "application/json");
    }));
    svr.Get("/api/presets", guarded([this](const httplib::Request&, httplib::Response& res) {
      json j = json::object();
      for (const auto& [name, text] : o.presets) j[name] = json::parse(text);
      res.set_content(j.dump(), "application/json");
    }));
    svr.Get("/api/defaults", guarded([](const httplib::Request&, httplib::Response& res) {
      json j;
      procgen::to_json(j, procgen::IslandSpec{});  // the paper's profile and resistance curves among them
      res.set_content(j.dump(), "application/json");
    }));
    svr.Post("/api/infer", guarded([this](const httplib::Request& req, httplib::Response& res) {
      const DecodedSketch s = sketch_of(req.body);
      latest_wins(res, [&] {
        const auto t0 = std::chrono::steady_clock::now();
        const cv::Mat1f h = infer::infer_heights(gen, {s}, io)[0];
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        send_heights(res, h, heights_meta(h, ms));
      });
    }));
    svr.Post("/api/generate", guarded([this](const httplib::Request& req, httplib::Response& res) {
      const json spec = json::parse(req.body, nullptr, false);
      if (spec.is_discarded()) throw BadRequest("the body is not valid JSON: send an island spec (docs/SPEC.md)");
      const int size = req.has_param("size") ? std::atoi(req.get_param_value("size").c_str()) : 256;
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
        send_heights(res, f.height_m, j);
      });
    }));
    svr.Post("/api/export", guarded([this](const httplib::Request& req, httplib::Response& res) {
      const std::string format = req.get_param_value("format"), name = req.get_param_value("name");
      check_name(name);
      static const std::map<std::string, std::string> ext = {{"exr", ".height.exr"}, {"png16", ".height.png"},
                                                             {"r16", ".r16"},        {"glb", ".glb"},
                                                             {"obj", ".obj"},        {"sketch", ".sketch.png"},
                                                             {"spec", ".spec.json"}};
      if (!ext.count(format)) throw BadRequest("format '" + format + "': use exr, png16, r16, glb, obj, sketch or spec");
      const json body = json::parse(req.body, nullptr, false);
      if (body.is_discarded() || !body.is_object())
        throw BadRequest("the body must be JSON: {\"sketch_png\": base64} or {\"spec\": {...}, \"size\": N}");
      const bool from_spec = body.contains("spec");
      if (!from_spec && !body.contains("sketch_png")) throw BadRequest("the body needs sketch_png or spec");
      if (format == "spec" && !from_spec) throw BadRequest("format spec needs a spec (curves mode)");
      // The source again (deterministic), then the CLI's writer for the format.
      cv::Mat1f h;
      cv::Mat3b label;
      json spec_json;
      double mpp = 0;
      {
        std::lock_guard<std::mutex> lock(compute);
        if (from_spec) {
          procgen::IslandSpec sp;
          const procgen::IslandFields f = island_of(body["spec"], body.value("size", 256), &sp);
          h = f.height_m;
          label = encode_labels(f.label, sp.subsidence);
          procgen::to_json(spec_json, sp);
          mpp = sp.world_size_m / h.cols;
        } else {
          const DecodedSketch s = sketch_of(base64_decode(body["sketch_png"].get<std::string>()));
          h = infer::infer_heights(gen, {s}, io)[0];
          label = encode_labels(s.label, s.subsidence);
          mpp = 6000.0 / h.cols;
        }
      }
      std::error_code ec;
      fs::create_directories(o.out_dir, ec);
      ensure_writable_dir(o.out_dir);
      const fs::path path = o.out_dir / (name + ext.at(format));
      const double lo = gen.range.lo_m, hi = gen.range.hi_m;
      StagedOutputs staged;
      staged.write(path, [&](const fs::path& t) {
        if (format == "exr") write_exr_height(t, h, {{"reefgen:version", kVersion}, {"reefgen:metres_per_pixel", std::to_string(mpp)}});
        else if (format == "png16") infer::write_png16(t, h, lo, hi);
        else if (format == "r16") {
          // Unity's terrains are 2^n + 1 samples a side: resample to that.
          cv::Mat1f r;
          cv::resize(h, r, {h.cols + 1, h.rows + 1}, 0, 0, cv::INTER_LINEAR);
          infer::write_r16(t, r, lo, hi);
        } else if (format == "glb") infer::write_glb(t, h, infer::MeshOptions{mpp, 1.0});
        else if (format == "obj") infer::write_obj(t, h, infer::MeshOptions{mpp, 1.0});
        else if (format == "sketch") write_png(t, label);
        else write_json_atomic(t, spec_json);
      });
      staged.commit();
      const std::string bytes = read_text(path);
      res.set_header("Content-Disposition", "attachment; filename=\"" + path.filename().string() + "\"");
      res.set_header("X-Reefgen-Path", fs::absolute(path).string());
      res.set_content(bytes, format == "spec" ? "application/json" : "application/octet-stream");
    }));
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
  } catch (const std::invalid_argument& e) {
    throw Error(std::string("--precision: ") + e.what());
  }
  if (m.o.max_side < 64 || m.o.max_side > 4096) throw Error("studio: max_side must be in 64..4096");
  m.routes();
}

StudioServer::~StudioServer() { stop(); }

int StudioServer::bind() {
  Impl& m = *impl_;
  const int port = m.o.port == 0 ? m.svr.bind_to_any_port(m.o.host) : (m.svr.bind_to_port(m.o.host, m.o.port) ? m.o.port : -1);
  if (port < 0)
    throw Error("studio: cannot listen on " + m.o.host + ":" + std::to_string(m.o.port) +
                " (in use? choose another with --port)");
  return port;
}

void StudioServer::serve() { impl_->svr.listen_after_bind(); }

void StudioServer::stop() {
  if (impl_ && impl_->svr.is_running()) impl_->svr.stop();
}

}  // namespace reefgen::studio
