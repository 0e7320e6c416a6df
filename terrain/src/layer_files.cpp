#include <algorithm>
#include <cmath>
#include <mutex>

#include <opencv2/imgproc.hpp>

#include "reefgen/image_io.hpp"
#include "reefgen/io.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/version.hpp"

namespace reefgen::terrain {

namespace {

double max_of(const cv::Mat1f& m) {
  double hi = 0;
  cv::minMaxLoc(m, nullptr, &hi);
  return hi;
}

cv::Mat1b to_8bit(const cv::Mat1f& m, double full_scale) {
  cv::Mat1b out;
  m.convertTo(out, CV_8U, 255.0 / full_scale);  // rounds and saturates
  return out;
}

}  // namespace

void add_layers_to_sidecar(nlohmann::json& sidecar, nlohmann::json layers) {
  for (const auto& [kind, file] : layers["files"].items()) sidecar["files"][kind] = file;
  sidecar["layers"] = std::move(layers);
}

namespace {
// Each layer file's kind (the sidecar's key) and suffix, in writing order.
constexpr std::pair<const char*, const char*> kLayerFiles[] = {
    {"flow", ".flow.png"},     {"slope", ".slope.png"},     {"wear", ".wear.png"},     {"deposit", ".deposit.png"},
    {"normal", ".normal.png"}, {"splat0", ".splat0.png"}, {"splat1", ".splat1.png"}, {"materials", ".materials.png"}};
}  // namespace

uint64_t stage_rain_file(StagedOutputs& staged, const std::string& prefix, const cv::Mat1f& rain_mm_yr, double mpp) {
  uint64_t bytes = 0;
  staged.write(prefix + kRainFileSuffix, [&](const fs::path& p) {
    write_exr_height(p, rain_mm_yr, {{"reefgen:version", kVersion}, {"reefgen:units", "rain, mm/yr"},
                                     {"reefgen:metres_per_pixel", std::to_string(mpp)}});
    bytes = fs::file_size(p);
  });
  return bytes;
}

std::vector<std::string> layer_file_suffixes() {
  std::vector<std::string> out;
  for (const auto& [kind, suffix] : kLayerFiles) out.push_back(suffix);
  return out;
}

nlohmann::json layer_file_names(const std::string& prefix) {
  nlohmann::json files = nlohmann::json::object();
  for (const auto& [kind, suffix] : kLayerFiles) files[kind] = fs::path(prefix + suffix).filename().string();
  return files;
}

nlohmann::json layer_files_description(double dx, const LayerParams& params, const LayerScales& s) {
  nlohmann::json materials = nlohmann::json::array();
  for (int m = 0; m < kNumMaterials; ++m)
    materials.push_back({{"name", material_name(m)}, {"file", m < 4 ? "splat0" : "splat1"}, {"channel", std::string(1, "RGBA"[m % 4])}});
  return {{"flow", {{"encoding", "area_m2 = cell_area_m2 * 10^((value - 1) / 65534 * log10_max) on land (value >= 1); 0 = sea"},
                    {"cell_area_m2", dx * dx}, {"log10_max", s.flow_log10_max(dx)}}},
          {"slope", {{"encoding", "degrees = value * 90 / 255"}}},
          {"wear", {{"encoding", "metres = value * scale_m / 255"}, {"scale_m", s.wear_scale_m()}}},
          {"deposit", {{"encoding", "metres = value * scale_m / 255"}, {"scale_m", s.deposit_scale_m()}}},
          {"normal", {{"convention", "OpenGL: R = east, G = north (+Y, up in the image), B = up; value = 127.5 (n + 1)"}}},
          {"materials", materials},
          {"material_weights", "8-bit, summing to 255 at every pixel"},
          {"rules", params}};
}

nlohmann::json stage_layer_files(StagedOutputs& staged, const std::string& prefix, const Layers& L, double dx,
                                 const LayerParams& params, int threads, const LayerScales* given) {
  const int H = L.slope_deg.rows, W = L.slope_deg.cols;
  const double cell_m2 = dx * dx;
  // This field's own maxima unless the scales are given (a world's tiles share the world's).
  const LayerScales scales = given ? *given : LayerScales{max_of(L.flow_area_m2), max_of(L.wear_m), max_of(L.deposit_m)};
  // Flow: v = 1 + 65534 · log10(A / a) / log10(A_max / a) on land (A at
  // least one cell a), 0 at sea only: a land cell draining only itself (or,
  // routed with shared flow across a world tile, less) was 0, read as sea.
  const double log_max = scales.flow_log10_max(dx);
  cv::Mat1w flow(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double a = L.flow_area_m2(y, x);
      flow(y, x) = a > 0 ? cv::saturate_cast<uint16_t>(1.0 + 65534.0 * std::log10(std::max(1.0, a / cell_m2)) / log_max) : 0;
    }
  const double wear_scale = scales.wear_scale_m(), deposit_scale = scales.deposit_scale_m();
  // Each file is prepared and encoded in its own job: the jobs run together.
  std::vector<StagedOutputs::Job> jobs;
  const nlohmann::json files = layer_file_names(prefix);
  auto put = [&](const char* suffix, std::function<void(const fs::path&)> writer) {
    jobs.emplace_back(prefix + suffix, std::move(writer));
  };
  put(".flow.png", [&](const fs::path& p) { write_png(p, flow); });
  put(".slope.png", [&](const fs::path& p) { write_png(p, to_8bit(L.slope_deg, 90.0)); });
  put(".wear.png", [&](const fs::path& p) { write_png(p, to_8bit(L.wear_m, wear_scale)); });
  put(".deposit.png", [&](const fs::path& p) { write_png(p, to_8bit(L.deposit_m, deposit_scale)); });
  put(".normal.png", [&](const fs::path& p) {
    cv::Mat3b normal(H, W);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const cv::Vec3f n = L.normal(y, x);
        auto enc = [](float c) { return cv::saturate_cast<uint8_t>(127.5f * (c + 1.f)); };
        normal(y, x) = cv::Vec3b(enc(n[2]), enc(n[1]), enc(n[0]));  // BGR in memory = RGB (x, y, z) in the file
      }
    write_png(p, normal);
  });
  std::array<cv::Mat4b, 2> splat;
  std::once_flag splat_once;
  for (int s = 0; s < 2; ++s)
    put(s == 0 ? ".splat0.png" : ".splat1.png", [&, s](const fs::path& p) {
      std::call_once(splat_once, [&] { splat = splat_maps(L); });
      cv::Mat4b bgra;
      cv::cvtColor(splat[size_t(s)], bgra, cv::COLOR_RGBA2BGRA);  // the file's R, G, B, A = materials 4s … 4s+3
      write_png(p, bgra);
    });
  put(".materials.png", [&](const fs::path& p) { write_png(p, material_colour_map(L)); });
  staged.write_all(jobs, threads);
  nlohmann::json out = layer_files_description(dx, params, scales);
  out["files"] = files;
  return out;
}

}  // namespace reefgen::terrain
