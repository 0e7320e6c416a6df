// Building a training set on disk (docs/DATASET.md): pairs written as
// SPLIT/INDEX.label.png + SPLIT/INDEX.height.exr with a manifest, resumable,
// sharded over machines and merged with checksums verified; and its stats.
// Every pair is a pure function of (seed, index), so a build can be resumed,
// sharded and verified by rebuilding.
#include "reefgen/augment/build.hpp"
#include "reefgen/augment/manifest.hpp"
#include "build_layouts.hpp"

#include <array>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <regex>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/io.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/terrain/layers.hpp"
#include "reefgen/version.hpp"

namespace reefgen::augment {

using nlohmann::json;


std::pair<int, int> parse_shard(const std::string& s) {
  std::smatch m;
  static const std::regex re(R"((\d{1,6})/(\d{1,6}))");
  if (!std::regex_match(s, m, re)) throw Error("--shard " + s + ": must be I/N with 0 ≤ I < N ≤ 999999, e.g. 0/4");
  const int i = std::stoi(m[1]), n = std::stoi(m[2]);
  if (n < 1 || i >= n) throw Error("--shard " + s + ": need 0 ≤ I < N");
  return {i, n};
}

namespace {

std::string pair_stem(const PairInfo& info) {
  char name[32];
  std::snprintf(name, sizeof name, "%08lld", static_cast<long long>(info.index));
  return std::string(split_name(info.split)) + "/" + name;
}

std::string manifest_name(int i, int n) {
  return n == 1 ? "manifest.jsonl" : "manifest.shard-" + std::to_string(i) + "-of-" + std::to_string(n) + ".jsonl";
}

// Verifies that existing files hold exactly this pair (a resumed build), or
// throws naming the file. Returns false when the files are absent.
bool existing_matches(const fs::path& label_path, const fs::path& height_path, const cv::Mat3b& label_bgr,
                      const Pair& pair) {
  const bool hl = fs::exists(label_path), hh = fs::exists(height_path);
  if (!hl && !hh) return false;
  if (hl != hh) return false;  // interrupted between the two writes: rewrite both
  cv::Mat l;
  try {
    l = read_image(label_path, cv::IMREAD_UNCHANGED);
  } catch (const Error&) {
  }
  if (l.empty() || l.type() != CV_8UC3 || cv::norm(l, label_bgr, cv::NORM_INF) != 0)
    throw Error(label_path.string() + " is corrupt or from another dataset; delete it or build into an empty folder");
  cv::Mat1f h;
  try {
    h = read_exr_height(height_path);
  } catch (const Error&) {
    throw Error(height_path.string() + " is corrupt or from another dataset; delete it or build into an empty folder");
  }
  if (h.size() != pair.height_m.size() || cv::norm(h, pair.height_m, cv::NORM_INF) != 0)
    throw Error(height_path.string() + " is corrupt or from another dataset; delete it or build into an empty folder");
  return true;
}

// The layer files of one pair (docs/LAYERS.md), from its regions; the
// augmented pair has no heights before erosion, so wear and deposit are 0.
// Written again on a resumed build (same bytes: a pure function of the pair).
// Returns the manifest's fields: the files, their checksums, the scales.
json write_pair_layers(const fs::path& dir, const std::string& stem, const Pair& pair) {
  const double mpp = kCanvasWorldSizeM / pair.height_m.cols;
  const terrain::Layers L = terrain::compute_layers(pair.height_m, cv::Mat1f(), pair.label, mpp);
  StagedOutputs staged;
  const json side = terrain::stage_layer_files(staged, (dir / stem).string(), L, mpp, {});
  staged.commit();
  const std::string folder = fs::path(stem).parent_path().string();
  json files = json::object(), sums = json::object();
  for (const auto& [kind, name] : side["files"].items()) {
    files[kind] = folder + "/" + name.get<std::string>();
    sums[kind] = file_checksum(dir / files[kind].get<std::string>());
  }
  return {{"layers", files},
          {"layers_fnv64", sums},
          {"flow_log10_max", side["flow"]["log10_max"]},
          {"flow_cell_area_m2", side["flow"]["cell_area_m2"]}};
}

}  // namespace

namespace {

void check_build_options(const BuildOptions& a) {
  if (a.threads < 1 || a.threads > 256) throw Error("--threads must be in 1..256");
  if (a.tar_mb < 1 || a.tar_mb > 65536) throw Error("--tar-mb must be in 1..65536 (MiB a WebDataset shard holds)");
  if (a.layout == DatasetLayout::Reefgen) return;
  const std::string f = std::string("--format ") + to_string(a.layout);
  if (a.layers) throw Error(f + ": --layers is for reefgen's layout only; drop one of them");
  if (a.shard != "0/1")
    throw Error(f + ": --shard is for reefgen's layout only (dataset merge joins those); build this layout on one machine");
}

// A folder that is not a dataset is refused unless empty: the build writes
// dataset.json, manifest.jsonl and split folders and would replace a user's
// file of the same name. Its own files (locks, splits) are fine: shards of
// one folder start side by side.
void refuse_foreign_folder(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw Error(dir.string() + ": exists and is not a folder; choose another --out");
  if (!fs::is_directory(dir, ec) || fs::exists(dir / "dataset.json", ec)) return;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    const bool own = name.rfind(".reefgen.shard-", 0) == 0 ||
                     ((name == "train" || name == "val" || name == "test") && e.is_directory(ec));
    if (!own)
      throw Error(dir.string() + ": not a reefgen dataset and not empty (holds " + name +
                  "); build into an empty or new folder");
  }
}

// dataset.json: what a resumed build must match (seed, params, layout).
void write_dataset_meta(const fs::path& dir, const DatasetParams& p, const BuildOptions& a) {
  json meta = {{"tool", "reefgen"},
               {"format", 1},
               {"seed", a.seed},
               {"params", p},
               {"height_normalisation_m", {layouts::kNormFloorM, layouts::kNormPeakM}},
               {"sea_level_m", 0.0},
               {"label_encoding", "HSV: hue 60*(id+1) deg for island, beach, lagoon, reef; 0 deg abyss; V = 1 - 0.75*subsidence"},
               {"files", "SPLIT/INDEX.label.png (RGB 8-bit) + SPLIT/INDEX.height.exr (float32, channel Y, metres)"}};
  if (a.layers) meta["layers"] = terrain::layer_file_suffixes();
  if (a.layout != DatasetLayout::Reefgen) {
    meta["layout"] = to_string(a.layout);
    meta.update(layouts::layout_description(a.layout, p.size_px));
    if (a.layout == DatasetLayout::WebDataset) meta["tar_mb"] = a.tar_mb;
  }
  const fs::path meta_path = dir / "dataset.json";
  if (fs::exists(meta_path)) {
    json old = read_json(meta_path);
    old.erase("version");
    if (old != meta)
      throw Error(meta_path.string() + " describes another dataset (its seed, params, --format, --tar-mb or --layers differ); use an empty --out folder");
  }
  meta["version"] = kVersion;
  write_json_atomic(meta_path, meta);
}

// One pair in reefgen's layout: SPLIT/INDEX.label.png + .height.exr (and
// the layer files), or the same files from an interrupted build, verified.
layouts::PairFiles write_reefgen_pair(const fs::path& dir, const std::string& stem, const PairInfo& info,
                                      const Pair& pair, bool with_layers) {
  layouts::PairFiles out;
  const fs::path label_path = dir / (stem + ".label.png"), height_path = dir / (stem + ".height.exr");
  const cv::Mat3b label_bgr = encode_labels(pair.label, pair.subsidence);
  out.reused = existing_matches(label_path, height_path, label_bgr, pair);
  if (!out.reused) {
    // Uncompressed EXR, zlib level 1 PNG: compressing cost more than
    // generating the pair (noisy floats shrink by only ~20 %).
    write_exr_height(height_path, pair.height_m, {{"reefgen:version", kVersion}}, 0);
    write_png(label_path, label_bgr, 1);
  }
  out.record = layouts::pair_record(info, pair);
  out.record.update({{"label", stem + ".label.png"},
                     {"height", stem + ".height.exr"},
                     {"label_fnv64", file_checksum(label_path)},
                     {"height_fnv64", file_checksum(height_path)}});
  if (with_layers) out.record.update(write_pair_layers(dir, stem, pair));
  return out;
}

}  // namespace

BuildResult build_dataset(const DatasetParams& p, const BuildOptions& a) {
  check_build_options(a);
  const auto [shard_i, shard_n] = parse_shard(a.shard);
  const fs::path dir = a.out;
  refuse_foreign_folder(dir);
  ensure_writable_dir(dir);
  // One builder per shard of a folder (shards of one folder may run side by
  // side); a killed builder's temp files are dropped, its finished pairs kept.
  // The lock file goes when the build ends (it was left in every dataset).
  const DirLock lock(dir, "dataset shard " + a.shard,
                     ".reefgen.shard-" + std::to_string(shard_i) + "-of-" + std::to_string(shard_n) + ".lock", true);
  remove_stale_temps(dir);
  // Before any split folder: another dataset's folder is left as it was.
  write_dataset_meta(dir, p, a);
  const bool per_pair = a.layout != DatasetLayout::WebDataset;
  const std::vector<Split> splits{Split::kTrain, Split::kVal, Split::kTest};
  if (per_pair)
    for (auto s : splits) {
      ensure_writable_dir(dir / split_name(s));
      remove_stale_temps(dir / split_name(s));
    }

  // Shard I makes the pairs I, I + N, I + 2N, ...: counted, never listed
  // (a list of 1e8 indices held 800 MB before the first pair).
  const size_t shard_pairs = p.count > shard_i ? size_t((p.count - shard_i + shard_n - 1) / shard_n) : 0;
  const int64_t first = shard_i, step = shard_n;
  const auto index_of = [first, step](size_t k) { return first + int64_t(k) * step; };
  Progress progress("dataset", shard_pairs, a.quiet);
  if (a.layout == DatasetLayout::WebDataset) return layouts::build_webdataset(p, a, progress);
  // Lines are streamed to the manifest's temporary file in index order as soon
  // as the pairs before them are done: memory holds only the few lines that
  // finished out of order, whatever the dataset size. imagefolder's
  // SPLIT/metadata.jsonl likewise.
  AtomicTextWriter manifest(dir / manifest_name(shard_i, shard_n));
  std::map<std::string, std::unique_ptr<AtomicTextWriter>> metadata;
  if (a.layout == DatasetLayout::ImageFolder)
    for (auto s : splits) metadata[split_name(s)] = std::make_unique<AtomicTextWriter>(dir / split_name(s) / "metadata.jsonl");
  std::mutex order_mutex;
  std::map<size_t, layouts::PairFiles> pending;
  size_t next_line = 0;
  auto put_line = [&](size_t k, layouts::PairFiles f) {
    std::lock_guard<std::mutex> hold(order_mutex);
    pending.emplace(k, std::move(f));
    for (auto it = pending.begin(); it != pending.end() && it->first == next_line; it = pending.erase(it), ++next_line) {
      manifest.write(it->second.record.dump() + "\n");
      if (!it->second.metadata_line.empty())
        metadata.at(it->second.record.at("split").get<std::string>())->write(it->second.metadata_line + "\n");
    }
  };
  std::atomic<size_t> reused{0};
  parallel_for(
      shard_pairs, a.threads,
      [&](size_t k) {
        PairInfo info;
        const Pair pair = make_pair(a.seed, index_of(k), p, &info);
        const std::string stem = pair_stem(info);
        layouts::PairFiles f = a.layout == DatasetLayout::Reefgen ? write_reefgen_pair(dir, stem, info, pair, a.layers)
                                                                  : layouts::write_pair(a.layout, dir, stem, info, pair);
        if (f.reused) ++reused;
        put_line(k, std::move(f));
      },
      [&](size_t d) { progress.tick(d); });
  if (next_line != shard_pairs) throw Error(dir.string() + ": internal error: manifest incomplete");
  for (auto& [split, writer] : metadata) writer->commit();
  manifest.commit();
  return {dir / manifest_name(shard_i, shard_n), shard_pairs, size_t(reused)};
}

MergeResult merge_dataset(const fs::path& dir) {
  const json meta = read_json(dir / "dataset.json");
  const int64_t count = meta.at("params").at("count").get<int64_t>();
  std::vector<fs::path> shards;
  int n = 0;
  static const std::regex re(R"(manifest\.shard-(\d{1,6})-of-(\d{1,6})\.jsonl)");
  for (const auto& e : fs::directory_iterator(dir)) {
    std::smatch m;
    const std::string name = e.path().filename().string();
    if (!std::regex_match(name, m, re)) continue;
    const int sn = std::stoi(m[2]);
    if (sn < 1) throw Error(e.path().string() + ": a shard of 0 shards; delete this file");
    if (n && sn != n) throw Error(dir.string() + ": shard manifests of different N (" + std::to_string(n) + ", " + std::to_string(sn) + ")");
    n = sn;
    shards.push_back(e.path());
  }
  if (shards.empty()) throw Error(dir.string() + ": no manifest.shard-I-of-N.jsonl to merge");
  if (static_cast<int>(shards.size()) != n)
    throw Error(dir.string() + ": " + std::to_string(shards.size()) + " of " + std::to_string(n) + " shard manifests present; build the missing shards first");
  // Shard I holds the indices i with i % N == I in increasing order, so the
  // merged manifest is read off the shards round-robin: streamed, flat memory.
  std::vector<std::ifstream> in(static_cast<size_t>(n));
  for (const auto& sp : shards) {
    std::smatch m;
    const std::string name = sp.filename().string();
    std::regex_match(name, m, re);
    const int i = std::stoi(m[1]);
    if (i >= n) throw Error(sp.string() + ": shard " + std::to_string(i) + " of " + std::to_string(n) + " does not exist; delete this file");
    in[static_cast<size_t>(i)].open(sp);
  }
  AtomicTextWriter merged(dir / "manifest.jsonl");
  std::set<std::string> listed;  // file names, to find foreign files afterwards
  for (int64_t i = 0; i < count; ++i) {
    const fs::path s = dir / manifest_name(int(i % n), n);
    std::string line;
    if (!std::getline(in[static_cast<size_t>(i % n)], line))
      throw Error(s.string() + ": ends before pair " + std::to_string(i) + "; rebuild that shard");
    json r;
    try {
      r = parse_json_checked(line, s.string());
    } catch (const json::exception&) {
      throw Error(s.string() + ": corrupt line; rebuild that shard");
    }
    if (r.at("index").get<int64_t>() != i)
      throw Error(s.string() + ": expected pair " + std::to_string(i) + ", found " + r.at("index").dump() + "; rebuild that shard");
    for (const char* kind : {"label", "height"}) {
      const std::string rel = r.at(kind).get<std::string>();
      const fs::path f = dir / rel;
      if (!fs::exists(f) || file_checksum(f) != r.at(std::string(kind) + "_fnv64").get<std::string>())
        throw Error(f.string() + ": missing or checksum mismatch; rebuild its shard");
      listed.insert(rel);
    }
    if (r.contains("layers"))
      for (const auto& [kind, rel] : r["layers"].items()) {
        const fs::path f = dir / rel.get<std::string>();
        if (!fs::exists(f) || file_checksum(f) != r.at("layers_fnv64").at(kind).get<std::string>())
          throw Error(f.string() + ": missing or checksum mismatch; rebuild its shard");
        listed.insert(rel.get<std::string>());
      }
    merged.write(r.dump() + "\n");
  }
  for (size_t k = 0; k < in.size(); ++k) {
    std::string extra;
    if (std::getline(in[k], extra) && !extra.empty())
      throw Error((dir / manifest_name(int(k), n)).string() + ": more pairs than dataset.json's count; rebuild that shard");
  }
  // Files in the split folders that no manifest lists: another build's, or copied in by mistake.
  std::vector<std::string> foreign;
  for (auto sp : {Split::kTrain, Split::kVal, Split::kTest})
    if (fs::exists(dir / split_name(sp)))
      for (const auto& e : fs::directory_iterator(dir / split_name(sp))) {
        const std::string rel = std::string(split_name(sp)) + "/" + e.path().filename().string();
        if (!listed.count(rel)) foreign.push_back(rel);
      }
  if (!foreign.empty())
    throw Error(dir.string() + ": " + std::to_string(foreign.size()) + " file(s) no manifest lists, e.g. " + foreign.front() +
                "; remove them (or build into a clean folder) and merge again");
  merged.commit();
  return {dir / "manifest.jsonl", shards.size(), count};
}

json dataset_stats(const fs::path& dir, int sheet_pairs, bool quiet, bool verify) {
  if (sheet_pairs < 0 || sheet_pairs > 1024) throw Error("--sheet must be in 0..1024");
  const json meta = read_json(dir / "dataset.json");
  const fs::path manifest = dir / "manifest.jsonl";
  ManifestCheck check;
  check.verify_checksums = verify;
  check.threads = default_threads();
  check.quiet = quiet;
  std::vector<ManifestPair> pairs = read_manifest(dir, check);
  std::map<std::string, int64_t> per_split;
  std::array<double, kNumRegions> region_px{};
  std::vector<int64_t> lambda_hist(10, 0);
  double hmin = 1e30, hmax = -1e30, total_px = 0;
  int64_t n = 0;
  std::vector<cv::Mat> tiles;
  const int tile = 128;
  std::vector<json> records;
  for (ManifestPair& p : pairs) {
    if (!p.record.contains("subsidence") || !p.record["subsidence"].is_number())
      throw Error(manifest.string() + ":" + std::to_string(p.line) +
                  ": not a pair record (no subsidence); rebuild the dataset (it resumes)");
    records.push_back(std::move(p.record));
  }
  const int size_px = meta.contains("params") ? meta["params"].value("size_px", 0) : 0;
  Progress progress("stats", records.size(), quiet);
  for (const auto& r : records) {
    ++per_split[r.at("split").get<std::string>()];
    const fs::path lp = dir / r.at("label").get<std::string>(), hp = dir / r.at("height").get<std::string>();
    const auto d = read_sketch(lp);
    const cv::Mat1f h = read_exr_height(hp);
    for (const auto& [m, path] : {std::pair<cv::Size, fs::path>{d.label.size(), lp}, {h.size(), hp}})
      if (size_px > 0 && (m.width != size_px || m.height != size_px))
        throw Error(path.string() + ": " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", not " +
                    std::to_string(size_px) + "x" + std::to_string(size_px) + " as dataset.json says; rebuild this pair");
    if (!cv::checkRange(h, true))
      throw Error(hp.string() + ": holds NaN or infinite heights; rebuild this pair (delete it and run dataset build again)");
    for (int y = 0; y < d.label.rows; ++y)
      for (int x = 0; x < d.label.cols; ++x) region_px[d.label(y, x)] += 1;
    total_px += static_cast<double>(d.label.total());
    const double lam = r.at("subsidence").get<double>();
    ++lambda_hist[std::min(9, static_cast<int>(lam * 10))];
    double lo, hi;
    cv::minMaxLoc(h, &lo, &hi);
    hmin = std::min(hmin, lo);
    hmax = std::max(hmax, hi);
    if (static_cast<int>(tiles.size()) < sheet_pairs) {
      cv::Mat lab = read_image(lp, cv::IMREAD_COLOR), prev, a, b;
      cv::resize(lab, a, {tile, tile}, 0, 0, cv::INTER_NEAREST);
      cv::resize(render_preview(h), b, {tile, tile}, 0, 0, cv::INTER_AREA);
      cv::hconcat(a, b, prev);
      tiles.push_back(prev);
    }
    progress.tick(static_cast<size_t>(++n));
  }
  json out_j = {{"pairs", n}, {"per_split", per_split}, {"height_range_m", {hmin, hmax}}, {"seed", meta.at("seed")}};
  json fractions = json::object();
  for (int i = 0; i < kNumRegions; ++i) fractions[kRegionNames[i]] = total_px > 0 ? region_px[i] / total_px : 0.0;
  out_j["region_pixel_fraction"] = fractions;
  out_j["subsidence_histogram"] = {{"bin_width", 0.1}, {"counts", lambda_hist}};
  if (!tiles.empty()) {
    // Grid of label | height previews, 4 pairs per row.
    const int cols = 4, rows = (static_cast<int>(tiles.size()) + cols - 1) / cols;
    cv::Mat sheet(rows * tile, cols * 2 * tile, CV_8UC3, cv::Scalar(40, 40, 40));
    for (size_t k = 0; k < tiles.size(); ++k)
      tiles[k].copyTo(sheet(cv::Rect(static_cast<int>(k % cols) * 2 * tile, static_cast<int>(k / cols) * tile, 2 * tile, tile)));
    write_png(dir / "contact_sheet.png", sheet);
    out_j["contact_sheet"] = "contact_sheet.png";
  }
  write_json_atomic(dir / "stats.json", out_j);
  return out_j;
}


}  // namespace reefgen::augment
