// build_dataset's layouts for other tools (build_layouts.hpp): pix2pix's
// aligned images, Hugging Face's image folder, WebDataset's tar shards.
#include "build_layouts.hpp"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "reefgen/augment/formats.hpp"
#include "reefgen/constants.hpp"
#include "reefgen/files.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/labels.hpp"

namespace reefgen::augment::layouts {

using nlohmann::json;

namespace {

// zlib level of the label PNGs, as reefgen's own layout (the same bytes).
constexpr int kLabelPngLevel = 1;

std::string corrupt(const fs::path& f) {
  return f.string() + " is corrupt or from another dataset; delete it or build into an empty folder";
}

// Writes `bytes` to `path` atomically, or finds them there already (a
// resumed build): true then. Other bytes there are refused.
bool put_bytes(const fs::path& path, const std::string& bytes) {
  std::error_code ec;
  if (fs::exists(path, ec)) {
    if (read_text(path, bytes.size() + 1) != bytes) throw Error(corrupt(path));
    return true;
  }
  write_file_atomic(path, bytes.data(), bytes.size());
  return false;
}

std::string key_of(int64_t index) {
  char key[32];
  std::snprintf(key, sizeof key, "%08lld", static_cast<long long>(index));
  return key;
}

}  // namespace

json pair_record(const PairInfo& info, const Pair& pair) {
  double lo, hi;
  cv::minMaxLoc(pair.height_m, &lo, &hi);
  return {{"index", info.index},
          {"split", split_name(info.split)},
          {"configuration", info.configuration},
          {"subsidence", info.subsidence},
          {"seed", info.seed},
          {"age_myr", info.age_myr < 0 ? json() : json(info.age_myr)},
          {"maturity", info.maturity},
          {"ruggedness", info.ruggedness},
          {"augmentation", info.augmentation},
          {"height_range_m", {lo, hi}}};
}

PairFiles write_pair(DatasetLayout layout, const fs::path& dir, const std::string& stem, const PairInfo& info,
                     const Pair& pair) {
  PairFiles out;
  out.record = pair_record(info, pair);
  const cv::Mat3b label_bgr = encode_labels(pair.label, pair.subsidence);
  if (layout == DatasetLayout::Pix2pix) {
    const std::string ab = aligned_png16(label_bgr, pair.height_m, kNormFloorM, kNormPeakM);
    out.reused = put_bytes(dir / (stem + ".png"), ab);
    out.record["ab"] = stem + ".png";
    out.record["ab_fnv64"] = bytes_checksum(ab);
    return out;
  }
  // imagefolder: the label map is the image (the same PNG as reefgen's
  // layout); the heights a .npy beside it, which image loaders skip.
  const std::string png = encode_png8(label_bgr, kLabelPngLevel), npy = npy_bytes(pair.height_m);
  const bool had_png = put_bytes(dir / (stem + ".png"), png), had_npy = put_bytes(dir / (stem + ".height.npy"), npy);
  out.reused = had_png && had_npy;
  // metadata.jsonl: the pair's record with the names Hugging Face joins on.
  const std::string name = fs::path(stem).filename().string();
  json meta = out.record;
  // The augmentation record as one JSON string: its keys differ from pair to
  // pair (paste, translate_skipped, affine ...), and Hugging Face's folder
  // builder refuses metadata whose rows have different features.
  meta["augmentation"] = out.record["augmentation"].dump();
  meta.update({{"file_name", name + ".png"}, {"height_file", name + ".height.npy"}});
  out.metadata_line = meta.dump();
  out.record.update({{"label", stem + ".png"},
                     {"height", stem + ".height.npy"},
                     {"label_fnv64", bytes_checksum(png)},
                     {"height_fnv64", bytes_checksum(npy)}});
  return out;
}

json layout_description(DatasetLayout layout, int size_px) {
  const json range = {{"floor_m", kNormFloorM}, {"peak_m", kNormPeakM}};
  switch (layout) {
    case DatasetLayout::Pix2pix:
      return {{"files", "SPLIT/INDEX.png: A|B, " + std::to_string(2 * size_px) + "x" + std::to_string(size_px) +
                            " RGB 16-bit; A the label map, B the heights in grey"},
              {"heights", "metres = floor_m + B / 65535 * (peak_m - floor_m); 8-bit readers (PIL keeps the high byte): B = 256 * B8 + 127.5, within 1.29 m"},
              {"range", range}};
    case DatasetLayout::ImageFolder:
      return {{"files", "SPLIT/INDEX.png (label map, RGB 8-bit) + SPLIT/INDEX.height.npy (float32 metres) + "
                        "SPLIT/metadata.jsonl (file_name, height_file, the pair's record)"}};
    default:
      return {{"files", "SPLIT-NNNNNN.tar holding INDEX.label.png (RGB 8-bit), INDEX.height.npy (float32 metres), "
                        "INDEX.json (the pair's record); SPLIT.index.json lists the shards (wids' shard index)"},
              {"range", range}};
  }
}

namespace {

// A new shard: a temporary file renamed into place by commit() (common's
// AtomicTextWriter, which writes bytes as they are).
class FileSink : public ByteSink {
 public:
  explicit FileSink(const fs::path& path) : file_(path) {}
  void put(const char* data, size_t n) override { file_.write(data, n); }
  void commit() { file_.commit(); }

 private:
  AtomicTextWriter file_;
};

// A shard an interrupted build finished: its bytes must be these.
class CompareSink : public ByteSink {
 public:
  explicit CompareSink(const fs::path& path) : path_(path) {
    // A FIFO or a device in the shard's place would block the read or never end.
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
      throw Error(path.string() + " is not a regular file (a folder, FIFO or device); delete it or build into an empty folder");
    in_.open(path, std::ios::binary);
    if (!in_) throw Error("cannot read " + path.string() + ": " + std::strerror(errno));
  }
  void put(const char* data, size_t n) override {
    buf_.resize(n);
    if (!in_.read(buf_.data(), std::streamsize(n)) || std::memcmp(buf_.data(), data, n) != 0)
      throw Error(corrupt(path_));
  }
  void finish() {
    if (in_.peek() != std::char_traits<char>::eof()) throw Error(corrupt(path_));
  }

 private:
  fs::path path_;
  std::ifstream in_;
  std::vector<char> buf_;
};

// One sample's members and its manifest line.
struct Sample {
  std::string key, label_png, height_npy, record_json;
  json manifest;
};

Sample make_sample(uint64_t seed, int64_t index, const DatasetParams& p, const std::string& shard) {
  PairInfo info;
  const Pair pair = make_pair(seed, index, p, &info);
  Sample s;
  s.key = key_of(index);
  s.label_png = encode_png8(encode_labels(pair.label, pair.subsidence), kLabelPngLevel);
  s.height_npy = npy_bytes(pair.height_m);
  json record = pair_record(info, pair);
  record["sea_level_m"] = 0.0;
  s.record_json = record.dump();
  s.manifest = record;
  s.manifest["shard"] = shard;
  s.manifest["key"] = s.key;
  s.manifest["label_fnv64"] = bytes_checksum(s.label_png);
  s.manifest["height_fnv64"] = bytes_checksum(s.height_npy);
  s.manifest["json_fnv64"] = bytes_checksum(s.record_json);
  return s;
}

// Pairs `indices` into shard `name`, in order; returns the manifest lines.
// Generation runs on a.threads; the tar is written in index order as the
// samples before each are done (memory holds those finished out of order).
std::vector<std::string> write_shard(const DatasetParams& p, const BuildOptions& a, const std::string& name,
                                     const std::vector<int64_t>& indices, bool resume,
                                     const std::function<void(size_t)>& tick) {
  const fs::path path = a.out / name;
  std::unique_ptr<FileSink> file;
  std::unique_ptr<CompareSink> same;
  if (resume) same = std::make_unique<CompareSink>(path);
  else file = std::make_unique<FileSink>(path);
  TarWriter tar(resume ? static_cast<ByteSink&>(*same) : *file);
  std::vector<std::string> lines(indices.size());
  std::mutex m;
  std::map<size_t, Sample> pending;
  size_t next = 0;
  parallel_for(
      indices.size(), a.threads,
      [&](size_t k) {
        Sample s = make_sample(a.seed, indices[k], p, name);
        std::lock_guard<std::mutex> hold(m);
        pending.emplace(k, std::move(s));
        for (auto it = pending.begin(); it != pending.end() && it->first == next; it = pending.erase(it), ++next) {
          const Sample& t = it->second;
          tar.add(t.key + ".label.png", t.label_png);
          tar.add(t.key + ".height.npy", t.height_npy);
          tar.add(t.key + ".json", t.record_json);
          lines[it->first] = t.manifest.dump();
        }
      },
      tick);
  tar.finish();
  if (resume) same->finish();
  else file->commit();
  return lines;
}

}  // namespace

BuildResult build_webdataset(const DatasetParams& p, const BuildOptions& a, Progress& progress) {
  const size_t per_shard =
      std::max<size_t>(1, size_t(a.tar_mb) * (size_t(1) << 20) / tar_sample_bound(p.size_px));
  AtomicTextWriter manifest(a.out / "manifest.jsonl");
  size_t done = 0, reused = 0;
  for (Split split : {Split::kTrain, Split::kVal, Split::kTest}) {
    json shardlist = json::array();
    // One shard's indices at a time, found by a pass over the dataset per
    // split: memory does not grow with --count (a list of every index per
    // split held 800 MB and cost 12 s before the first pair at 1e8).
    std::vector<int64_t> part;
    auto write_part = [&] {
      char name[64];
      std::snprintf(name, sizeof name, "%s-%06zu.tar", split_name(split), shardlist.size());
      std::error_code ec;
      const bool resume = fs::exists(a.out / name, ec);
      for (const std::string& line : write_shard(p, a, name, part, resume, [&](size_t d) { progress.tick(done + d); }))
        manifest.write(line + "\n");
      done += part.size();
      if (resume) reused += part.size();
      shardlist.push_back({{"url", name}, {"nsamples", part.size()}, {"filesize", fs::file_size(a.out / name)}});
      part.clear();
    };
    for (int64_t i = 0; i < p.count; ++i) {
      if (split_of(a.seed, i / p.levels, p) != split) continue;
      part.push_back(i);
      if (part.size() == per_shard) write_part();
    }
    if (!part.empty()) write_part();
    write_json_atomic(a.out / (std::string(split_name(split)) + ".index.json"),
                      {{"__kind__", "wids-shard-index-v1"},
                       {"wids_version", 1},
                       {"name", split_name(split)},
                       {"shardlist", shardlist}});
  }
  manifest.commit();
  return {a.out / "manifest.jsonl", size_t(p.count), reused};
}

}  // namespace reefgen::augment::layouts
