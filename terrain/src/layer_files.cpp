#include <algorithm>
#include <cmath>
#include <mutex>

#include <opencv2/imgproc.hpp>

#include "reefgen/io.hpp"
#include "reefgen/terrain/layers.hpp"

namespace reefgen::terrain {

namespace {

// Largest value of a layer, at least `floor` (an all-zero layer still gets a scale).
double scale_of(const cv::Mat1f& m, double floor) {
  double hi = 0;
  cv::minMaxLoc(m, nullptr, &hi);
  return std::max(hi, floor);
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

std::vector<std::string> layer_file_suffixes() {
  return {".flow.png", ".slope.png", ".wear.png", ".deposit.png", ".normal.png", ".splat0.png", ".splat1.png",
          ".materials.png"};
}

nlohmann::json stage_layer_files(StagedOutputs& staged, const std::string& prefix, const Layers& L, double dx,
                                 const LayerParams& params, int threads, const LayerScales* scales) {
  const int H = L.slope_deg.rows, W = L.slope_deg.cols;
  const double cell_m2 = dx * dx;
  // Flow: v = 65535 · log10(A / a) / log10(A_max / a) on land, 0 at sea and
  // where a cell drains only itself.
  const double flow_max = scales ? std::max(scales->flow_area_m2, cell_m2) : scale_of(L.flow_area_m2, cell_m2);
  const double log_max = std::max(1e-6, std::log10(flow_max / cell_m2));
  cv::Mat1w flow(H, W);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double a = L.flow_area_m2(y, x);
      flow(y, x) = a > 0 ? cv::saturate_cast<uint16_t>(65535.0 * std::log10(std::max(1.0, a / cell_m2)) / log_max) : 0;
    }
  // An all-zero layer still gets a scale.
  constexpr double kMinScaleM = 0.01;
  const double wear_scale = scales ? std::max(scales->wear_m, kMinScaleM) : scale_of(L.wear_m, kMinScaleM);
  const double deposit_scale = scales ? std::max(scales->deposit_m, kMinScaleM) : scale_of(L.deposit_m, kMinScaleM);
  // Each file is prepared and encoded in its own job: the jobs run together.
  std::vector<StagedOutputs::Job> jobs;
  nlohmann::json files = nlohmann::json::object();
  auto put = [&](const char* kind, const char* suffix, std::function<void(const fs::path&)> writer) {
    jobs.emplace_back(prefix + suffix, std::move(writer));
    files[kind] = fs::path(prefix + suffix).filename().string();
  };
  put("flow", ".flow.png", [&](const fs::path& p) { write_png(p, flow); });
  put("slope", ".slope.png", [&](const fs::path& p) { write_png(p, to_8bit(L.slope_deg, 90.0)); });
  put("wear", ".wear.png", [&](const fs::path& p) { write_png(p, to_8bit(L.wear_m, wear_scale)); });
  put("deposit", ".deposit.png", [&](const fs::path& p) { write_png(p, to_8bit(L.deposit_m, deposit_scale)); });
  put("normal", ".normal.png", [&](const fs::path& p) {
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
    put(s == 0 ? "splat0" : "splat1", s == 0 ? ".splat0.png" : ".splat1.png", [&, s](const fs::path& p) {
      std::call_once(splat_once, [&] { splat = splat_maps(L); });
      cv::Mat4b bgra;
      cv::cvtColor(splat[size_t(s)], bgra, cv::COLOR_RGBA2BGRA);  // the file's R, G, B, A = materials 4s … 4s+3
      write_png(p, bgra);
    });
  put("materials", ".materials.png", [&](const fs::path& p) { write_png(p, material_colour_map(L)); });
  staged.write_all(jobs, threads);
  nlohmann::json materials = nlohmann::json::array();
  for (int m = 0; m < kNumMaterials; ++m)
    materials.push_back({{"name", material_name(m)}, {"file", m < 4 ? "splat0" : "splat1"}, {"channel", std::string(1, "RGBA"[m % 4])}});
  return {{"files", files},
          {"flow", {{"encoding", "area_m2 = cell_area_m2 * 10^(value / 65535 * log10_max); 0 = sea"},
                    {"cell_area_m2", cell_m2}, {"log10_max", log_max}}},
          {"slope", {{"encoding", "degrees = value * 90 / 255"}}},
          {"wear", {{"encoding", "metres = value * scale_m / 255"}, {"scale_m", wear_scale}}},
          {"deposit", {{"encoding", "metres = value * scale_m / 255"}, {"scale_m", deposit_scale}}},
          {"normal", {{"convention", "OpenGL: R = east, G = north (+Y, up in the image), B = up; value = 127.5 (n + 1)"}}},
          {"materials", materials},
          {"material_weights", "8-bit, summing to 255 at every pixel"},
          {"rules", params}};
}

}  // namespace reefgen::terrain
