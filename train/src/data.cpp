#include "reefgen/train/data.hpp"

#include <fstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/augment/manifest.hpp"
#include "reefgen/io.hpp"
#include "reefgen/rng.hpp"

namespace reefgen::train {

using nlohmann::json;

const std::vector<PairRef>& DatasetInfo::split(const std::string& name) const {
  if (name == "train") return train;
  if (name == "val") return val;
  if (name == "test") return test;
  throw Error("unknown split '" + name + "'; use train, val or test");
}

namespace {
// The record's erosion maturity (datasets before maturities were drawn have
// none: their erosion is the configured one, maturity 1).
double maturity_of(const augment::ManifestPair& p, const fs::path& manifest) {
  const auto it = p.record.find("maturity");
  if (it == p.record.end() || it->is_null()) return 1;
  if (!it->is_number() || !(it->get<double>() > 0))
    throw Error(manifest.string() + ":" + std::to_string(p.line) + ": \"maturity\" must be a positive number; rebuild the dataset");
  return it->get<double>();
}
}  // namespace

DatasetInfo open_dataset(const fs::path& dir, const augment::ManifestCheck& check) {
  DatasetInfo d;
  d.dir = dir;
  const fs::path meta = dir / "dataset.json";
  if (!fs::exists(meta)) throw Error(meta.string() + ": missing; is " + dir.string() + " a folder made by `reefgen dataset build`?");
  const json j = read_json(meta);
  try {
    d.size_px = j.at("params").at("size_px");
    const auto r = j.at("height_normalisation_m");
    d.range = {r.at(0).get<double>(), r.at(1).get<double>()};
  } catch (const json::exception& e) {
    throw Error(meta.string() + ": no params.size_px or height_normalisation_m (" + std::string(e.what()) + ")");
  }
  if (!(d.range.hi_m > d.range.lo_m)) throw Error(meta.string() + ": height_normalisation_m must be [lo, hi] with lo < hi");
  const fs::path manifest = dir / "manifest.jsonl";
  for (augment::ManifestPair& p : augment::read_manifest(dir, check)) {
    PairRef r{p.index, std::move(p.label), std::move(p.height), maturity_of(p, manifest)};
    if (p.split == "train") d.train.push_back(std::move(r));
    else if (p.split == "val") d.val.push_back(std::move(r));
    else d.test.push_back(std::move(r));
  }
  if (d.train.empty()) throw Error(manifest.string() + ": no training pairs");
  return d;
}

Sample load_sample(const DatasetInfo& d, const PairRef& p, const JitterOptions& jit, uint64_t seed, int in_channels) {
  const fs::path lp = d.dir / p.label, hp = d.dir / p.height;
  cv::Mat3b label;
  try {
    label = read_image(lp, cv::IMREAD_COLOR);
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (rebuild the dataset: it resumes)");
  }
  cv::Mat1f height = read_exr_height(hp);
  const int S = d.size_px;
  for (const auto& [m, path] : {std::pair<cv::Size, fs::path>{label.size(), lp}, {height.size(), hp}})
    if (m.width != S || m.height != S)
      throw Error(path.string() + ": " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", not " +
                  std::to_string(S) + "x" + std::to_string(S) + " as dataset.json says; rebuild the dataset");
  if (!cv::checkRange(height)) throw Error(hp.string() + ": contains NaN or infinite heights; rebuild this pair");
  if (jit.on) {
    Rng rng(seed);
    const int L = std::max(S, int(std::lround(S * jit.scale)));
    const int ox = L > S ? rng.uniform_int(0, L - S) : 0;
    const int oy = L > S ? rng.uniform_int(0, L - S) : 0;
    const bool flip = jit.flip && rng.uniform() < 0.5;
    if (L > S) {
      cv::Mat3b lr;
      cv::Mat1f hr;
      cv::resize(label, lr, {L, L}, 0, 0, cv::INTER_NEAREST);
      cv::resize(height, hr, {L, L}, 0, 0, cv::INTER_LINEAR);
      const cv::Rect crop(ox, oy, S, S);
      label = lr(crop).clone();
      height = hr(crop).clone();
    }
    if (flip) {
      cv::flip(label, label, 1);
      cv::flip(height, height, 1);
    }
  }
  // The maturity plane is constant: the jitter does not move it.
  return {model::network_input(label, in_channels, p.maturity), model::height_to_tensor(height, d.range)};
}

size_t sample_at(uint64_t seed, int64_t q, size_t n) {
  const int64_t epoch = q / int64_t(n);
  const size_t pos = size_t(q % int64_t(n));
  // Fisher-Yates with our own RNG (std::shuffle differs between libraries).
  std::vector<size_t> perm(n);
  for (size_t i = 0; i < n; ++i) perm[i] = i;
  Rng rng(derive_seed(seed, uint64_t(epoch), "order"));
  for (size_t i = n; i > 1; --i) std::swap(perm[i - 1], perm[size_t(rng.uniform_int(0, int(i - 1)))]);
  return perm[pos];
}

Prefetcher::Prefetcher(std::function<Batch(int64_t)> make, int64_t first, int64_t end, int threads, int depth)
    : make_(std::move(make)), next_claim_(first), next_out_(first), end_(end), depth_(std::max(1, depth)) {
  for (int i = 0; i < std::max(1, threads); ++i) threads_.emplace_back([this] { work(); });
}

Prefetcher::~Prefetcher() {
  {
    std::lock_guard<std::mutex> lock(m_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) t.join();
}

void Prefetcher::work() {
  for (;;) {
    int64_t step;
    {
      std::unique_lock<std::mutex> lock(m_);
      cv_.wait(lock, [&] { return stop_ || error_ || next_claim_ >= end_ || next_claim_ < next_out_ + depth_; });
      if (stop_ || error_ || next_claim_ >= end_) return;
      step = next_claim_++;
    }
    try {
      Batch b = make_(step);
      std::lock_guard<std::mutex> lock(m_);
      ready_.emplace(step, std::move(b));
    } catch (...) {
      std::lock_guard<std::mutex> lock(m_);
      if (!error_) error_ = std::current_exception();
    }
    cv_.notify_all();
  }
}

Prefetcher::Batch Prefetcher::next() {
  std::unique_lock<std::mutex> lock(m_);
  if (next_out_ >= end_) throw std::logic_error("Prefetcher: read past the last step");
  cv_.wait(lock, [&] { return error_ || ready_.count(next_out_); });
  if (error_ && !ready_.count(next_out_)) std::rethrow_exception(error_);
  Batch b = std::move(ready_.at(next_out_));
  ready_.erase(next_out_++);
  lock.unlock();
  cv_.notify_all();
  return b;
}

}  // namespace reefgen::train
