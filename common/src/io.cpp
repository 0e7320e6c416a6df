#include "reefgen/io.hpp"
#include "reefgen/parallel.hpp"

#include <zlib.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <opencv2/imgcodecs.hpp>

namespace reefgen {

namespace {

// Temporary files being written, for a fatal signal's handler to unlink
// (SIGTERM, SIGHUP, an unhandled SIGINT): a fixed table of C strings, each
// published by its flag, so the handler only calls unlink (async-signal-safe).
// A slot is freed when its file is committed; when all are taken the oldest
// is reused (a stale entry only names a file that no longer exists).
constexpr size_t kLiveTemps = 256;
constexpr size_t kLiveTempPath = 4096;
struct LiveTemp {
  std::atomic<bool> ready{false};
  char path[kLiveTempPath];
};
LiveTemp g_live[kLiveTemps];
std::atomic<uint64_t> g_live_next{0};

void track_temp(const fs::path& tmp) {
  const std::string& s = tmp.native();
  if (s.size() >= kLiveTempPath) return;
  LiveTemp& t = g_live[g_live_next.fetch_add(1) % kLiveTemps];
  t.ready = false;
  std::memcpy(t.path, s.c_str(), s.size() + 1);
  t.ready = true;
}

void untrack_temp(const fs::path& tmp) {
  for (LiveTemp& t : g_live)
    if (t.ready && tmp.native() == t.path) t.ready = false;
}

extern "C" void unlink_temps_and_die(int sig) {
  for (LiveTemp& t : g_live)
    if (t.ready) ::unlink(t.path);
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// NAME_MAX of Linux filesystems (ext4, xfs, btrfs, tmpfs), bytes.
constexpr size_t kNameMaxBytes = 255;

// Unique temp name beside the destination (same filesystem, so rename is atomic).
fs::path temp_path_for(const fs::path& path) {
  static std::atomic<uint64_t> counter{0};
  const auto n = counter.fetch_add(1);
  const std::string suffix = ".tmp." + std::to_string(::getpid()) + "." + std::to_string(n);
  fs::path tmp = path;
  tmp += suffix;
  // A final name that fits the filesystem's 255 bytes must not fail for its
  // temporary name: past the limit, the name's head and "~" before the same
  // suffix (unique by itself; remove_stale_temps still knows it).
  const std::string name = path.filename().string();
  if (name.size() + suffix.size() > kNameMaxBytes)
    tmp = path.parent_path() / (name.substr(0, kNameMaxBytes - suffix.size() - 1) + "~" + suffix);
  track_temp(tmp);
  return tmp;
}

void commit_temp(const fs::path& tmp, const fs::path& path) {
  std::error_code ec;
  untrack_temp(tmp);
  fs::rename(tmp, path, ec);
  if (ec) {
    // The rename's own error: removing the temporary resets its own code
    // (the message used to read "rename failed (Success)").
    const std::string why = ec.message();
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("cannot write " + path.string() + ": rename failed (" + why + ")");
  }
}

}  // namespace

void remove_temps_on_fatal_signals() {
  for (int sig : {SIGTERM, SIGHUP, SIGINT}) ::signal(sig, unlink_temps_and_die);
}

void write_file_atomic(const fs::path& path, const void* data, size_t size) {
  const fs::path tmp = temp_path_for(path);
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f)
    throw Error("cannot write " + path.string() + ": " + std::strerror(errno) +
                " (check that the folder exists and is writable)");
  const size_t written = size ? std::fwrite(data, 1, size, f) : 0;
  const int err_write = (written != size) ? errno : 0;
  const int rc_close = std::fclose(f);
  if (written != size || rc_close != 0) {
    const int err = err_write ? err_write : errno;
    std::error_code ec;
    fs::remove(tmp, ec);
    throw Error("cannot write " + path.string() + ": " + std::strerror(err) + " (is the disk full?)");
  }
  commit_temp(tmp, path);
}

StagedOutputs::StagedOutputs(fs::path work_dir, fs::path base)
    : work_(fs::absolute(work_dir).lexically_normal()), base_(fs::absolute(base).lexically_normal()) {}

StagedOutputs::~StagedOutputs() {
  // A resumable run keeps what it staged for the next run.
  if (committed_ || !work_.empty()) return;
  std::error_code ec;
  for (const auto& t : temps_) fs::remove(t, ec);
}

fs::path StagedOutputs::kept_path(const fs::path& final_path) const {
  const fs::path rel = fs::absolute(final_path).lexically_normal().lexically_relative(base_);
  if (rel.empty() || *rel.begin() == "..")
    throw Error("internal: " + final_path.string() + " lies outside the resumable run's folder " + base_.string());
  return work_ / rel;
}

bool StagedOutputs::resumed(const fs::path& final_path) const {
  std::error_code ec;
  return !work_.empty() && fs::is_regular_file(kept_path(final_path), ec);
}

namespace {
// The writer names the temporary file; the user knows the final one.
std::string named_after_final(std::string what, const fs::path& tmp, const fs::path& final_path) {
  const std::string t = tmp.string(), f = final_path.string();
  for (size_t at = what.find(t); at != std::string::npos; at = what.find(t, at + f.size())) what.replace(at, t.size(), f);
  return what.empty() ? "cannot write " + f : what;
}
}  // namespace

fs::path StagedOutputs::stage(const fs::path& final_path) {
  if (committed_) throw Error("internal: " + final_path.string() + " staged after commit");
  std::error_code ec;
  if (const size_t n = final_path.filename().string().size(); n > kNameMaxBytes)
    throw Error("cannot write " + final_path.string() + ": its name is " + std::to_string(n) + " bytes, the filesystem allows " +
                std::to_string(kNameMaxBytes) + " (choose a shorter output name)");
  if (fs::is_directory(final_path, ec))
    throw Error("cannot write " + final_path.string() + ": it is a folder (choose another output name)");
  for (const auto& f : finals_) {
    // Two failed look-ups give two empty paths: not a clash.
    std::error_code e1, e2;
    const fs::path a = fs::weakly_canonical(f, e1), b = fs::weakly_canonical(final_path, e2);
    if (f == final_path || (!e1 && !e2 && a == b))
      throw Error("two outputs of this run are named " + final_path.string() + " (give each its own name)");
  }
  const fs::path dir = final_path.parent_path().empty() ? fs::path(".") : final_path.parent_path();
  if (std::find(swept_dirs_.begin(), swept_dirs_.end(), dir) == swept_dirs_.end()) {
    remove_stale_temps(dir);
    swept_dirs_.push_back(dir);
  }
  finals_.push_back(final_path);
  if (work_.empty()) {
    temps_.push_back(temp_path_for(final_path));
    return temps_.back();
  }
  const fs::path kept = kept_path(final_path);
  temps_.push_back(kept);
  // Temporaries a killed run left in work_dir go too (finished files stay).
  if (std::find(swept_dirs_.begin(), swept_dirs_.end(), kept.parent_path()) == swept_dirs_.end() &&
      fs::is_directory(kept.parent_path(), ec)) {
    remove_stale_temps(kept.parent_path());
    swept_dirs_.push_back(kept.parent_path());
  }
  if (fs::is_regular_file(kept, ec)) {
    ++resumed_count_;
    return {};
  }
  fs::create_directories(kept.parent_path(), ec);
  if (ec) throw Error("cannot write " + kept.parent_path().string() + ": " + ec.message() + " (is the disk full?)");
  return temp_path_for(kept);
}

void StagedOutputs::settle(const fs::path& tmp, const fs::path& final_path) {
  if (work_.empty() || tmp.empty()) return;
  commit_temp(tmp, kept_path(final_path));
}

void StagedOutputs::write(const fs::path& final_path, const std::function<void(const fs::path&)>& writer) {
  const fs::path tmp = stage(final_path);
  if (tmp.empty()) return;
  try {
    writer(tmp);
  } catch (const std::exception& e) {
    if (!work_.empty()) {
      std::error_code ec;
      fs::remove(tmp, ec);
    }
    throw Error(named_after_final(e.what(), tmp, final_path));
  }
  settle(tmp, final_path);
}

void StagedOutputs::write_all(const std::vector<Job>& jobs, int threads) {
  // Registered one by one (names checked, temporaries named), written together.
  std::vector<fs::path> tmps;
  for (const auto& job : jobs) tmps.push_back(stage(job.first));
  std::vector<std::string> errors(jobs.size());
  parallel_for(jobs.size(), threads, [&](size_t i) {
    if (tmps[i].empty()) return;  // resumed
    try {
      jobs[i].second(tmps[i]);
    } catch (const std::exception& e) {
      errors[i] = named_after_final(e.what(), tmps[i], jobs[i].first);
    }
  });
  for (size_t i = 0; i < jobs.size(); ++i)
    if (!errors[i].empty()) {
      if (!work_.empty())
        for (size_t k = 0; k < jobs.size(); ++k)
          if (!tmps[k].empty()) {
            std::error_code ec;
            fs::remove(tmps[k], ec);
          }
      throw Error(errors[i]);
    }
  for (size_t i = 0; i < jobs.size(); ++i) settle(tmps[i], jobs[i].first);
}

void StagedOutputs::commit() {
  std::error_code ec;
  for (size_t i = 0; i < temps_.size(); ++i) {
    if (fs::is_directory(finals_[i], ec))
      throw Error("cannot write " + finals_[i].string() + ": it is a folder (choose another output name)");
    if (!fs::exists(temps_[i], ec))
      throw Error("cannot write " + finals_[i].string() + ": its staged copy " + temps_[i].string() + " vanished");
  }
  for (size_t i = 0; i < temps_.size(); ++i) {
    // A resumed file's folder may not exist yet (it was made by the earlier run).
    if (!work_.empty() && finals_[i].has_parent_path()) fs::create_directories(finals_[i].parent_path(), ec);
    commit_temp(temps_[i], finals_[i]);
  }
  committed_ = true;
  if (!work_.empty()) fs::remove_all(work_, ec);
}

AtomicTextWriter::AtomicTextWriter(const fs::path& path) : path_(path), tmp_(temp_path_for(path)) {
  f_ = std::fopen(tmp_.c_str(), "wb");
  if (!f_)
    throw Error("cannot write " + path.string() + ": " + std::strerror(errno) +
                " (check that the folder exists and is writable)");
}

AtomicTextWriter::~AtomicTextWriter() {
  if (f_) {
    std::fclose(f_);
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
}

void AtomicTextWriter::write(const std::string& text) {
  if (!f_) throw Error("cannot write " + path_.string() + ": already committed");
  if (std::fwrite(text.data(), 1, text.size(), f_) != text.size())
    throw Error("cannot write " + path_.string() + ": " + std::strerror(errno) + " (disk full?)");
}

void AtomicTextWriter::commit() {
  FILE* f = f_;
  f_ = nullptr;
  if (std::fclose(f) != 0) {
    std::error_code ec;
    fs::remove(tmp_, ec);
    throw Error("cannot write " + path_.string() + ": " + std::strerror(errno) + " (disk full?)");
  }
  commit_temp(tmp_, path_);
}

void write_text_atomic(const fs::path& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

std::string read_text(const fs::path& path, size_t max_bytes) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw Error("cannot read " + path.string() + ": it is a folder, not a file");
  // O_NONBLOCK: opening a FIFO nobody writes to would block forever; opened
  // this way it returns at once, and a read then sees end-of-file unless a
  // writer (a shell's <(...), a pipe) holds the other end.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw Error("cannot read " + path.string() + ": " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st{};
  const bool fifo = ::fstat(fd, &st) == 0 && S_ISFIFO(st.st_mode);
  if (S_ISSOCK(st.st_mode)) throw Error("cannot read " + path.string() + ": it is a socket, not a file");
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  // Read in blocks up to the bound: /dev/zero or a FIFO has no size to check first.
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error("cannot read " + path.string() + ": " + std::strerror(errno));
    if (n == 0) break;
    out.append(buf, size_t(n));
    if (out.size() > max_bytes)
      throw Error("cannot read " + path.string() + ": larger than " + std::to_string(max_bytes >> 20) +
                  " MiB, not a file reefgen reads (check the path)");
  }
  if (fifo && out.empty())
    throw Error("cannot read " + path.string() + ": a FIFO (named pipe) with nothing written to it; pass a regular file");
  return out;
}

nlohmann::json read_json(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("cannot read " + path.string() + ": no such file");
  const std::string text = read_text(path, kMaxJsonBytes);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(path.string() + ": invalid JSON at byte " + std::to_string(e.byte) +
                " (fix the syntax; see docs/SPEC.md)");
  } catch (const nlohmann::json::out_of_range& e) {
    // 406: a number beyond a double (1e400). The library's text names
    // neither the file nor where; the number itself is the useful part.
    const std::string what = e.what();
    const size_t at = what.find("parsing '");
    const std::string number = at == std::string::npos ? "a number" : what.substr(at + 8);
    throw Error(path.string() + ": " + number + " is beyond the range of a number (about 1.8e308); use a finite value");
  } catch (const nlohmann::json::exception& e) {
    throw Error(path.string() + ": cannot read it as JSON (" + std::string(e.what()).substr(std::string(e.what()).find(']') + 2) +
                ")");
  }
}

void write_json_atomic(const fs::path& path, const nlohmann::json& j) {
  // Invalid UTF-8 (a file name in a sidecar) is replaced, not an exception.
  write_text_atomic(path, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

std::string image_damage(const std::string& b) {
  const auto* u = reinterpret_cast<const unsigned char*>(b.data());
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() >= 8 && std::memcmp(u, kPng, 8) == 0) {
    // Walk the chunks: each within the file and with its CRC, ending in IEND.
    size_t p = 8;
    while (p + 12 <= b.size()) {
      const uint32_t len = uint32_t(u[p]) << 24 | uint32_t(u[p + 1]) << 16 | uint32_t(u[p + 2]) << 8 | u[p + 3];
      if (len > b.size() - p - 12) return "truncated PNG (a chunk runs past the end of the file)";
      const uint32_t crc = uint32_t(crc32(0L, u + p + 4, uInt(len + 4)));
      const unsigned char* c = u + p + 8 + len;
      if (crc != (uint32_t(c[0]) << 24 | uint32_t(c[1]) << 16 | uint32_t(c[2]) << 8 | c[3])) {
        std::string type;  // printable: a damaged type may hold any byte
        for (int k = 4; k < 8; ++k) type += std::isalpha(u[p + k]) ? char(u[p + k]) : '?';
        return "damaged PNG (chunk " + type + " fails its CRC)";
      }
      if (b.compare(p + 4, 4, "IEND") == 0) return "";
      p += 12 + len;
    }
    return "truncated PNG (no IEND chunk)";
  }
  if (b.size() >= 2 && u[0] == 0xff && u[1] == 0xd8) {
    size_t end = b.size();
    while (end > 2 && (u[end - 1] == 0 || u[end - 1] == '\n' || u[end - 1] == '\r' || u[end - 1] == ' ')) --end;
    if (end < 4 || u[end - 2] != 0xff || u[end - 1] != 0xd9) return "truncated JPEG (no end-of-image marker)";
  }
  return "";
}

cv::Mat decode_image(const std::string& bytes, const std::string& name, int flags) {
  if (bytes.empty()) throw Error(name + ": empty file, not an image");
  if (const std::string bad = image_damage(bytes); !bad.empty())
    throw Error(name + ": " + bad + "; save or download the image again");
  // IMREAD_UNCHANGED also ignores a JPEG's EXIF orientation, so a phone
  // photo would come out turned from what its owner sees; a JPEG has no
  // alpha and no 16 bits to keep, so it is read as it is meant to be shown.
  const bool jpeg = bytes.size() > 3 && bytes.compare(0, 3, "\xFF\xD8\xFF") == 0;
  if (jpeg && flags == cv::IMREAD_UNCHANGED) flags = cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR;
  cv::Mat img;
  try {
    img = cv::imdecode(cv::Mat(1, int(bytes.size()), CV_8U, const_cast<char*>(bytes.data())), flags);
  } catch (const cv::Exception&) {
  }
  if (img.empty()) throw Error(name + ": not an image reefgen can decode (PNG, JPEG, TIFF, BMP or WebP)");
  return img;
}

cv::Mat read_image(const fs::path& path, int flags) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("cannot read " + path.string() + ": no such file");
  return decode_image(read_text(path, size_t(256) << 20), path.string(), flags);
}

void ensure_writable_dir(const fs::path& dir) {
  std::error_code ec;
  if (!dir.empty() && !fs::exists(dir, ec)) {
    fs::create_directories(dir, ec);
    if (ec) throw Error("cannot create folder " + dir.string() + ": " + ec.message());
  }
  const fs::path d = dir.empty() ? fs::path(".") : dir;
  if (!fs::is_directory(d, ec)) throw Error(d.string() + " is not a folder");
  if (::access(d.c_str(), W_OK) != 0)
    throw Error("folder " + d.string() + " is not writable: " + std::strerror(errno));
}

namespace {

void put_u32be(std::string& out, uint32_t v) {
  for (int k = 3; k >= 0; --k) out += char((v >> (8 * k)) & 0xff);
}

void put_chunk(std::string& out, const char type[4], const std::string& data) {
  put_u32be(out, uint32_t(data.size()));
  const size_t start = out.size();
  out.append(type, 4);
  out += data;
  put_u32be(out, uint32_t(crc32(0, reinterpret_cast<const Bytef*>(out.data() + start), uInt(out.size() - start))));
}

}  // namespace

// 8-bit grey, RGB or RGBA PNG with the Sub filter on every row and zlib's RLE
// strategy. libpng's adaptive filter search was 9 % of a dataset build; label
// maps are runs of one colour, which Sub turns into runs of zero bytes that
// RLE compresses as well as the search would.
std::string encode_png8(const cv::Mat& image, int level) {
  const int ch = image.channels(), W = image.cols, H = image.rows;
  if (image.depth() != CV_8U || (ch != 1 && ch != 3 && ch != 4)) throw Error("internal: encode_png8 takes 8-bit grey, BGR or BGRA");
  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put_u32be(ihdr, uint32_t(W));
  put_u32be(ihdr, uint32_t(H));
  ihdr += char(8);                    // bit depth
  ihdr += char(ch == 4 ? 6 : ch == 3 ? 2 : 0);  // colour type: RGBA, RGB or grey
  ihdr += std::string("\0\0\0", 3);  // deflate, adaptive filtering method 0, no interlace
  put_chunk(out, "IHDR", ihdr);
  std::vector<uint8_t> raw(size_t(H) * (size_t(W) * size_t(ch) + 1));
  uint8_t* d = raw.data();
  for (int y = 0; y < H; ++y) {
    const uint8_t* row = image.ptr<uint8_t>(y);
    *d++ = 1;  // filter type Sub
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < ch; ++c) {
        const int src = ch >= 3 ? (c < 3 ? 2 - c : 3) : 0;  // BGR(A) -> RGB(A)
        const uint8_t v = row[x * ch + src];
        const uint8_t left = x > 0 ? row[(x - 1) * ch + src] : 0;
        *d++ = uint8_t(v - left);
      }
  }
  z_stream z{};
  if (deflateInit2(&z, level, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK) throw Error("zlib: deflateInit2 failed");
  std::string idat(deflateBound(&z, uLong(raw.size())), '\0');
  z.next_in = raw.data();
  z.avail_in = uInt(raw.size());
  z.next_out = reinterpret_cast<Bytef*>(idat.data());
  z.avail_out = uInt(idat.size());
  const int rc = deflate(&z, Z_FINISH);
  idat.resize(idat.size() - z.avail_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw Error("zlib: deflate failed");
  put_chunk(out, "IDAT", idat);
  put_chunk(out, "IEND", "");
  return out;
}


void write_png(const fs::path& path, const cv::Mat& image, int level) {
  if (image.depth() == CV_8U && (image.channels() == 4 || image.channels() == 3 || image.channels() == 1)) {
    const std::string bytes = encode_png8(image, level);
    write_file_atomic(path, bytes.data(), bytes.size());
    return;
  }
  std::vector<uchar> buf;
  // A fixed level keeps the bytes reproducible.
  // Label maps and previews are runs of equal colours: the RLE strategy is
  // several times faster than the default at a similar size.
  if (!cv::imencode(".png", image, buf,
                    {cv::IMWRITE_PNG_COMPRESSION, level, cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_RLE}))
    throw Error("cannot encode PNG for " + path.string());
  write_file_atomic(path, buf.data(), buf.size());
}

void write_exr_height(const fs::path& path, const cv::Mat1f& height_m, const ExrAttributes& attrs, int zip_level) {
  write_exr_channel(path, height_m, "Y", attrs, zip_level);
}

void write_exr_channel(const fs::path& path, const cv::Mat1f& height_m, const std::string& channel,
                       const ExrAttributes& attrs, int zip_level) {
  CV_Assert(height_m.isContinuous());
  // No tool downstream survives a NaN or an infinite height: refuse to write
  // one rather than hand it on (it comes from parameters out of sane range).
  if (!cv::checkRange(height_m, true))
    throw Error("cannot write " + path.string() +
                ": the heights hold NaN or infinite values (a parameter far out of range? check the config)");
  Imf::Header header(height_m.cols, height_m.rows);
  // Level 0 stores the floats uncompressed: noisy float32 heights shrink by
  // only ~20 % under ZIP, which costs more time than generating them.
  header.compression() = zip_level > 0 ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION;
  if (zip_level > 0) header.zipCompressionLevel() = zip_level;
  header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
  for (const auto& [k, v] : attrs) header.insert(k, Imf::StringAttribute(v));
  Imf::FrameBuffer fb;
  fb.insert(channel, Imf::Slice(Imf::FLOAT, (char*)height_m.ptr<float>(), sizeof(float),
                            sizeof(float) * height_m.cols));
  const fs::path tmp = temp_path_for(path);
  try {
    Imf::OutputFile out(tmp.c_str(), header);
    out.setFrameBuffer(fb);
    out.writePixels(height_m.rows);
  } catch (const std::exception& e) {
    std::error_code ec;
    fs::remove(tmp, ec);
    throw Error("cannot write " + path.string() + ": " + e.what());
  }
  commit_temp(tmp, path);
}

cv::Mat1f read_exr_height(const fs::path& path, ExrAttributes* attrs) {
  if (!fs::exists(path)) throw Error("cannot read " + path.string() + ": no such file");
  try {
    Imf::InputFile in(path.c_str());
    const auto& h = in.header();
    const auto dw = h.dataWindow();
    const int w = dw.max.x - dw.min.x + 1, rows = dw.max.y - dw.min.y + 1;
    std::string channel = "Y";
    if (!h.channels().findChannel("Y")) {
      auto it = h.channels().begin();
      if (it == h.channels().end() || ++h.channels().begin() != h.channels().end())
        throw Error(path.string() + ": no channel Y (expected a single-channel height EXR)");
      channel = it.name();
    }
    cv::Mat1f out(rows, w);
    Imf::FrameBuffer fb;
    char* base = (char*)out.ptr<float>() - (dw.min.x + dw.min.y * (long)w) * (long)sizeof(float);
    fb.insert(channel, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    if (attrs) {
      for (auto it = h.begin(); it != h.end(); ++it)
        if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) (*attrs)[it.name()] = s->value();
    }
    return out;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error("cannot read " + path.string() + " as EXR: " + e.what());
  }
}

struct ExrRowReader::File {
  explicit File(const fs::path& p) : in(p.c_str()) {}
  Imf::InputFile in;
  std::string channel = "Y";
  Imath::Box2i dw;
};

ExrRowReader::ExrRowReader(const fs::path& path) : path_(path) {
  if (!fs::is_regular_file(path)) throw Error("cannot read " + path.string() + ": no such file");
  try {
    file_ = std::make_unique<File>(path);
    const auto& h = file_->in.header();
    file_->dw = h.dataWindow();
    size_ = cv::Size(file_->dw.max.x - file_->dw.min.x + 1, file_->dw.max.y - file_->dw.min.y + 1);
    if (!h.channels().findChannel("Y")) {
      auto it = h.channels().begin();
      if (it == h.channels().end() || ++h.channels().begin() != h.channels().end())
        throw Error(path.string() + ": no channel Y (expected a single-channel height EXR)");
      file_->channel = it.name();
    }
    for (auto it = h.begin(); it != h.end(); ++it)
      if (auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute())) attrs_[it.name()] = s->value();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error("cannot read " + path.string() + " as EXR: " + e.what());
  }
}

ExrRowReader::~ExrRowReader() = default;

cv::Mat1f ExrRowReader::rows(int y0, int n) {
  if (y0 < 0 || n < 1 || y0 + n > size_.height) throw Error("internal: rows outside " + path_.string());
  try {
    const int w = size_.width;
    cv::Mat1f out(n, w);
    Imf::FrameBuffer fb;
    const long first = file_->dw.min.y + y0;
    char* base = (char*)out.ptr<float>() - (file_->dw.min.x + first * (long)w) * (long)sizeof(float);
    fb.insert(file_->channel, Imf::Slice(Imf::FLOAT, base, sizeof(float), sizeof(float) * w));
    file_->in.setFrameBuffer(fb);
    file_->in.readPixels(int(first), int(first) + n - 1);
    return out;
  } catch (const std::exception& e) {
    throw Error("cannot read " + path_.string() + " as EXR: " + e.what());
  }
}

std::string file_checksum(const fs::path& path) {
  const std::string bytes = read_text(path);
  uint64_t h = 0xCBF29CE484222325ull;
  for (unsigned char c : bytes) { h ^= c; h *= 0x100000001B3ull; }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)h);
  return buf;
}

}  // namespace reefgen

namespace reefgen {

DirLock::DirLock(const fs::path& dir, const std::string& what, const std::string& lock_name) {
  const fs::path lock = dir / lock_name;
  fd_ = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw Error(lock.string() + ": cannot create the lock file (" + std::strerror(errno) + "); check the folder's permissions");
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    // The file stays empty (no PID in it): two builds of one dataset must
    // leave byte-identical folders.
    throw Error(dir.string() + ": another reefgen process is using this " + what +
                "; wait for it to finish or choose another folder");
  }
}

DirLock::~DirLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the flock
}

int remove_stale_temps(const fs::path& dir) {
  std::error_code ec;
  int removed = 0;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string name = e.path().filename().string();
    long pid = 0;
    size_t at = name.rfind(".tmp.");
    if (at != std::string::npos) {  // NAME.tmp.PID.N
      const std::string rest = name.substr(at + 5);
      const size_t dot = rest.find('.');
      if (dot == std::string::npos || dot == 0) continue;
      const std::string p = rest.substr(0, dot), n = rest.substr(dot + 1);
      if (p.find_first_not_of("0123456789") != std::string::npos || n.empty() ||
          n.find_first_not_of("0123456789") != std::string::npos)
        continue;
      pid = std::stol(p);
    } else if ((at = name.rfind(".tmp-")) != std::string::npos) {  // NAME.tmp-PID
      const std::string p = name.substr(at + 5);
      if (p.empty() || p.find_first_not_of("0123456789") != std::string::npos) continue;
      pid = std::stol(p);
    } else {
      continue;
    }
    if (pid <= 0 || pid == ::getpid()) continue;
    if (::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    if (fs::remove(e.path(), ec)) ++removed;
  }
  return removed;
}

void refuse_output_over_input(const std::vector<fs::path>& inputs, const std::vector<fs::path>& outputs) {
  std::error_code ec;
  for (const auto& out : outputs)
    for (const auto& in : inputs) {
      const bool same = fs::absolute(out, ec).lexically_normal() == fs::absolute(in, ec).lexically_normal() ||
                        (fs::exists(out, ec) && fs::exists(in, ec) && fs::equivalent(out, in, ec));
      if (same)
        throw Error(out.string() + ": this output is also an input (" + in.string() +
                    "); choose another output name so the input is not overwritten");
    }
}

double exr_metres_per_px(const ExrAttributes& attrs) {
  for (const char* key : {"reefgen:metres_per_pixel", "reefgen:metres_per_px"}) {
    const auto it = attrs.find(key);
    if (it == attrs.end()) continue;
    try {
      const double v = std::stod(it->second);
      if (v > 0 && std::isfinite(v)) return v;
    } catch (const std::exception&) {
    }
  }
  return 0;
}

}  // namespace reefgen
