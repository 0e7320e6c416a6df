#pragma once
// reefgen studio: one local web server, one page. The page paints
// a sketch (or drags the curve generator's inputs) and shows the island in 3D;
// this server answers it with the same code as the CLI.
//
// JSON API (docs/STUDIO.md):
//   GET  /api/info                 model, limits, version
//   GET  /api/presets              {name: spec} of the built-in island presets
//   GET  /api/defaults             the default spec (the paper's profile and resistance curves)
//   POST /api/infer                body: a sketch image (PNG/JPEG, ≤ max_side²), or with ?w=&h= the
//                                  canvas's raw RGBA; ?seed=, ?age_myr=, ?maturity= as infer's flags
//                                  -> heights: [uint32 LE n][n bytes JSON {size, min_m, max_m, lo_m,
//                                     hi_m, metres_per_px, ms}][size² float32 LE metres, row 0 = north];
//                                     with ?enc=u16 uint16 steps (the JSON says lo and step)
//   POST /api/variations?seed=S&n=N  body: as /api/infer -> {"seeds": [...], "previews": [base64 PNG]}
//   POST /api/generate?size=N      body: an island spec (docs/SPEC.md)
//                                  -> the same, its JSON also holding label_png (base64)
//   POST /api/layers?view=V        body: as export -> PNG of the materials or flow layer
//   POST /api/export?format=F&name=N   body: {"sketch_png": base64} or {"spec": {...}, "size": N}
//                                  writes OUT/N.ext with the CLI's writers and returns the file;
//                                  F: exr png16 r16 glb obj sketch spec, or a bundle (unity unreal
//                                  godot blender gis: OUT/N.<F>/ and its ZIP)
// Errors: HTTP 400/404/409/413 with {"error": one line}. One computation at a
// time; a request overtaken by a newer one while it waited gets 409 (the
// latest stroke wins).
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace reefgen::studio {

struct StudioOptions {
  std::string host = "127.0.0.1";              // bind address; loopback only by default
  int port = 8080;                             // 0 = any free port (tests)
  std::filesystem::path model;                 // generator file (the shipped model by default, resolved by the caller)
  std::filesystem::path out_dir = "studio-out";  // the only folder the server writes to
  std::filesystem::path assets_dir;            // the page: index.html, app.js, three.js (vendored by CMake)
  size_t max_body_bytes = 16u << 20;           // bytes per request; larger bodies get 413
  int max_side = 1024;                         // sketch / generated island side limit, pixels
  std::string precision = "auto";              // fp32 | bf16 | auto (infer's --precision)
  int head_deadline_ms = 10000;                // a request head must arrive whole within this, ms; 500..60000; else 408
  std::map<std::string, std::string> presets;  // name -> spec JSON text (the CLI's built-in presets)
};

class StudioServer {
 public:
  explicit StudioServer(StudioOptions options);  // loads the model; throws reefgen::Error naming what is wrong
  ~StudioServer();
  StudioServer(const StudioServer&) = delete;
  StudioServer& operator=(const StudioServer&) = delete;

  int bind();   // binds host:port, returns the port (the chosen one for port 0); throws on failure
  void serve(); // blocks until stop()
  void stop();  // safe from another thread or a signal-driven watcher

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Base64 (RFC 4648, with padding) for the JSON API.
std::string base64_encode(const void* data, size_t size);
std::string base64_decode(const std::string& text);  // throws reefgen::Error on bad input

}  // namespace reefgen::studio
