#include "reefgen/augment/manifest.hpp"

#include <fstream>
#include <unordered_map>

#include "reefgen/files.hpp"
#include "reefgen/parallel.hpp"

namespace reefgen::augment {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kRebuild = "rebuild the dataset (it resumes)";

// A manifest path may only name a file below the dataset folder: relative,
// no "..", so a hostile manifest cannot read /etc/passwd or another dataset.
bool inside_folder(const std::string& rel) {
  if (rel.empty() || rel.find('\0') != std::string::npos) return false;
  const fs::path p(rel);
  if (p.is_absolute() || p.has_root_name() || p.has_root_directory()) return false;
  for (const auto& part : p)
    if (part == "..") return false;
  return true;
}

bool is_string(const json& r, const char* key) { return r.contains(key) && r[key].is_string(); }

ManifestPair parse_line(const fs::path& manifest, const std::string& line, int64_t no, bool want_sums) {
  const std::string where = manifest.string() + ":" + std::to_string(no);
  // nlohmann's own errors would put "[json.exception...]" before the user:
  // every field is checked here instead.
  // The depth limit and repeated keys as every reefgen JSON (parse_json_checked).
  json r;
  try {
    r = parse_json_checked(line, where);
  } catch (const json::exception&) {
    r = json(json::value_t::discarded);
  }
  if (r.is_discarded() || !r.is_object() || !r.contains("index") || !r["index"].is_number_integer() ||
      !is_string(r, "label") || !is_string(r, "height") || !is_string(r, "split"))
    throw Error(where + ": not a pair record (truncated or edited manifest); " + kRebuild);
  ManifestPair p{no, r["index"].get<int64_t>(), r["split"], r["label"], r["height"], {}};
  if (p.split != "train" && p.split != "val" && p.split != "test")
    throw Error(where + ": unknown split '" + p.split + "'; " + kRebuild);
  for (const std::string* rel : {&p.label, &p.height})
    if (!inside_folder(*rel))
      throw Error(where + ": path '" + *rel + "' is outside the dataset folder; a manifest names files below it only (" +
                  kRebuild + ")");
  if (want_sums && !(is_string(r, "label_fnv64") && is_string(r, "height_fnv64")))
    throw Error(where + ": no checksums to verify the pair against; " + kRebuild + ", or pass --no-verify");
  p.record = std::move(r);
  return p;
}

// Every pair checked (parallel_for, common/parallel.hpp); the first failing
// one in manifest order is reported, so the message does not depend on the
// thread count.
void verify_files(const fs::path& dir, const fs::path& manifest, const std::vector<ManifestPair>& pairs,
                  const ManifestCheck& check) {
  std::vector<std::string> problem(pairs.size());
  Progress progress("verify", pairs.size(), check.quiet);
  auto check_pair = [&](size_t i) {
    const ManifestPair& p = pairs[i];
    const std::string where = " (" + manifest.filename().string() + ":" + std::to_string(p.line) + ")";
    for (const char* kind : {"label", "height"}) {
      const fs::path f = dir / p.record[kind].get<std::string>();
      std::error_code ec;
      if (!fs::is_regular_file(f, ec)) {
        problem[i] = f.string() + ": missing" + where + "; " + kRebuild;
        return;
      }
      if (file_checksum(f) != p.record[std::string(kind) + "_fnv64"].get<std::string>()) {
        problem[i] = f.string() + ": its bytes differ from the checksum the build recorded" + where +
                     " (changed or swapped after the build); " + kRebuild + ", or pass --no-verify";
        return;
      }
    }
  };
  parallel_for(pairs.size(), std::max(1, std::min(check.threads, 256)), check_pair,
               [&](size_t done) { progress.tick(done); });
  for (const std::string& why : problem)
    if (!why.empty()) throw Error(why);
}

}  // namespace

namespace {

// `dataset build --format pix2pix|webdataset|imagefolder` writes for other
// tools; reefgen's trainer and stats read reefgen's layout.
void refuse_foreign_layout(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir / "dataset.json", ec)) return;
  const nlohmann::json meta = read_json(dir / "dataset.json");
  const std::string layout = meta.value("layout", "reefgen");
  if (layout != "reefgen")
    throw Error(dir.string() + ": a dataset in the " + layout + " layout (dataset build --format " + layout +
                "), for other tools; reefgen reads its own layout: build one without --format");
}

}  // namespace

std::vector<ManifestPair> read_manifest(const fs::path& dir, const ManifestCheck& check) {
  const fs::path manifest = dir / "manifest.jsonl";
  refuse_foreign_layout(dir);
  if (!fs::exists(manifest))
    throw Error(manifest.string() + ": missing; finish the build (or `reefgen dataset merge` its shards)");
  std::vector<ManifestPair> pairs;
  std::unordered_map<int64_t, int64_t> line_of;  // index -> first line
  std::ifstream in(manifest);
  std::string line;
  for (int64_t no = 1; std::getline(in, line); ++no) {
    if (line.empty()) continue;
    ManifestPair p = parse_line(manifest, line, no, check.verify_checksums);
    const auto [it, fresh] = line_of.emplace(p.index, no);
    if (!fresh)
      throw Error(manifest.string() + ":" + std::to_string(no) + ": pair " + std::to_string(p.index) +
                  " is listed again (first at line " + std::to_string(it->second) + "); " + kRebuild);
    pairs.push_back(std::move(p));
  }
  if (check.verify_checksums) verify_files(dir, manifest, pairs, check);
  return pairs;
}

}  // namespace reefgen::augment
