#include "reefgen/image_io.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <opencv2/imgcodecs.hpp>

namespace reefgen {

using detail::commit_temp;
using detail::temp_path_for;

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

namespace {
uint32_t be32(const unsigned char* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }
uint32_t le32(const unsigned char* p) { return uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0]; }
uint16_t be16(const unsigned char* p) { return uint16_t(p[0] << 8 | p[1]); }
uint16_t le16(const unsigned char* p) { return uint16_t(p[1] << 8 | p[0]); }

// The frame header of a JPEG: the first SOFn marker's height and width.
cv::Size jpeg_size(const unsigned char* u, size_t n) {
  size_t p = 2;
  while (p + 9 < n) {
    if (u[p] != 0xff) return {};
    const unsigned char m = u[p + 1];
    if (m == 0xff) { ++p; continue; }  // fill bytes
    if (m == 0xd8 || (m >= 0xd0 && m <= 0xd7) || m == 0x01) { p += 2; continue; }
    const size_t len = be16(u + p + 2);
    const bool sof = m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc;
    if (sof) return {be16(u + p + 7), be16(u + p + 5)};
    p += 2 + len;
  }
  return {};
}

// A TIFF's first directory: its ImageWidth (256) and ImageLength (257) tags.
cv::Size tiff_size(const unsigned char* u, size_t n) {
  const bool le = u[0] == 'I';
  auto r16 = [&](size_t p) { return le ? le16(u + p) : be16(u + p); };
  auto r32 = [&](size_t p) { return le ? le32(u + p) : be32(u + p); };
  const size_t ifd = r32(4);
  if (ifd + 2 > n) return {};
  const size_t count = r16(ifd);
  int w = 0, h = 0;
  for (size_t k = 0; k < count && ifd + 2 + 12 * (k + 1) <= n; ++k) {
    const size_t e = ifd + 2 + 12 * k;
    const unsigned tag = r16(e), type = r16(e + 2);
    const int v = int(std::min<uint32_t>(type == 3 ? r16(e + 8) : r32(e + 8), uint32_t(1) << 30));
    if (tag == 256) w = v;
    if (tag == 257) h = v;
  }
  return w > 0 && h > 0 ? cv::Size(w, h) : cv::Size();
}
// A PNM header (P1…P6): the magic, then width and height as decimal
// tokens, whitespace and # comments between them.
cv::Size pnm_size(const std::string& b) {
  size_t p = 2;
  int v[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    while (p < b.size() && (std::isspace(static_cast<unsigned char>(b[p])) || b[p] == '#')) {
      if (b[p] == '#')
        while (p < b.size() && b[p] != '\n') ++p;
      else
        ++p;
    }
    int64_t n = 0;
    const size_t start = p;
    while (p < b.size() && std::isdigit(static_cast<unsigned char>(b[p])) && n <= (int64_t(1) << 30)) n = n * 10 + (b[p++] - '0');
    if (p == start) return {};
    v[k] = int(std::min<int64_t>(n, int64_t(1) << 30));
  }
  return {v[0], v[1]};
}

}  // namespace

cv::Size declared_image_size(const std::string& b) {
  const auto* u = reinterpret_cast<const unsigned char*>(b.data());
  const size_t n = b.size();
  auto capped = [](uint32_t v) { return int(std::min<uint32_t>(v, uint32_t(1) << 30)); };
  if (n >= 24 && std::memcmp(u, "\x89PNG\r\n\x1a\n", 8) == 0 && std::memcmp(u + 12, "IHDR", 4) == 0)
    return {capped(be32(u + 16)), capped(be32(u + 20))};
  if (n >= 4 && u[0] == 0xff && u[1] == 0xd8) return jpeg_size(u, n);
  if (n >= 26 && u[0] == 'B' && u[1] == 'M')
    return {capped(uint32_t(std::abs(int32_t(le32(u + 18))))), capped(uint32_t(std::abs(int32_t(le32(u + 22)))))};
  if (n >= 30 && std::memcmp(u, "RIFF", 4) == 0 && std::memcmp(u + 8, "WEBP", 4) == 0) {
    if (std::memcmp(u + 12, "VP8X", 4) == 0)
      return {int(1 + (u[24] | u[25] << 8 | u[26] << 16)), int(1 + (u[27] | u[28] << 8 | u[29] << 16))};
    if (std::memcmp(u + 12, "VP8L", 4) == 0) {
      const uint32_t bits = le32(u + 21);
      return {int(1 + (bits & 0x3fff)), int(1 + ((bits >> 14) & 0x3fff))};
    }
    if (std::memcmp(u + 12, "VP8 ", 4) == 0) return {le16(u + 26) & 0x3fff, le16(u + 28) & 0x3fff};
  }
  if (n >= 8 && ((u[0] == 'I' && u[1] == 'I' && u[2] == 42) || (u[0] == 'M' && u[1] == 'M' && u[3] == 42)))
    return tiff_size(u, n);
  if (n >= 7 && u[0] == 'P' && u[1] >= '1' && u[1] <= '6') return pnm_size(b);
  return {};
}

cv::Mat decode_image(const std::string& bytes, const std::string& name, int flags, int max_side) {
  if (bytes.empty()) throw Error(name + ": empty file, not an image");
  const cv::Size d = declared_image_size(bytes);
  if (d.width > max_side || d.height > max_side)
    throw Error(name + ": " + std::to_string(d.width) + "×" + std::to_string(d.height) + " pixels; at most " +
                std::to_string(max_side) + " a side here (scale the image down first)");
  // No size read from a header (another format OpenCV knows, PNM or HDR,
  // or a header cut short): nothing bounds what decoding would allocate.
  if (d.width <= 0 || d.height <= 0)
    throw Error(name + ": not an image reefgen can decode (PNG, JPEG, TIFF, BMP, WebP or PNM; save it as PNG)");
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
  if (img.empty()) throw Error(name + ": not an image reefgen can decode (PNG, JPEG, TIFF, BMP, WebP or PNM)");
  return img;
}

cv::Mat read_image(const fs::path& path, int flags, int max_side) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("cannot read " + path.string() + ": no such file");
  return decode_image(read_text(path, size_t(256) << 20), path.string(), flags, max_side);
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

namespace {

// Grey, RGB or RGBA PNG of 8 or 16 bits with the Sub filter on every row and
// zlib's RLE strategy. libpng's adaptive filter search was 9 % of a dataset
// build (and 40 % of a pix2pix one, on 16 bits); label maps are runs of one
// colour, which Sub turns into runs of zero bytes that RLE compresses as well
// as the search would.
template <class T>
std::string encode_png_sub(const cv::Mat& image, int level) {
  constexpr int bytes_per_sample = int(sizeof(T));
  const int ch = image.channels(), W = image.cols, H = image.rows, bpp = ch * bytes_per_sample;
  std::string out("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  put_u32be(ihdr, uint32_t(W));
  put_u32be(ihdr, uint32_t(H));
  ihdr += char(8 * bytes_per_sample);              // bit depth
  ihdr += char(ch == 4 ? 6 : ch == 3 ? 2 : 0);  // colour type: RGBA, RGB or grey
  ihdr += std::string("\0\0\0", 3);  // deflate, adaptive filtering method 0, no interlace
  put_chunk(out, "IHDR", ihdr);
  std::vector<uint8_t> raw(size_t(H) * (size_t(W) * size_t(bpp) + 1));
  std::vector<uint8_t> row_bytes(size_t(W) * size_t(bpp));
  uint8_t* d = raw.data();
  for (int y = 0; y < H; ++y) {
    const T* row = image.ptr<T>(y);
    // The row as PNG stores it: RGB(A) order, 16-bit samples big-endian.
    uint8_t* r = row_bytes.data();
    for (int x = 0; x < W; ++x)
      for (int c = 0; c < ch; ++c) {
        const int src = ch >= 3 ? (c < 3 ? 2 - c : 3) : 0;  // BGR(A) -> RGB(A)
        const T v = row[x * ch + src];
        if constexpr (bytes_per_sample == 2) *r++ = uint8_t(v >> 8);
        *r++ = uint8_t(v & 0xff);
      }
    *d++ = 1;  // filter type Sub: each byte minus the byte one pixel to the left
    for (int i = 0; i < W * bpp; ++i) *d++ = uint8_t(row_bytes[size_t(i)] - (i >= bpp ? row_bytes[size_t(i - bpp)] : 0));
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

}  // namespace

std::string encode_png8(const cv::Mat& image, int level) {
  const int ch = image.channels();
  if (image.depth() != CV_8U || (ch != 1 && ch != 3 && ch != 4)) throw Error("internal: encode_png8 takes 8-bit grey, BGR or BGRA");
  return encode_png_sub<uint8_t>(image, level);
}

std::string encode_png16(const cv::Mat& image, int level) {
  const int ch = image.channels();
  if (image.depth() != CV_16U || (ch != 1 && ch != 3 && ch != 4)) throw Error("internal: encode_png16 takes 16-bit grey, BGR or BGRA");
  return encode_png_sub<uint16_t>(image, level);
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

cv::Mat1f read_exr_height(const fs::path& path, ExrAttributes* attrs, int max_side) {
  if (!fs::exists(path)) throw Error("cannot read " + path.string() + ": no such file");
  try {
    Imf::InputFile in(path.c_str());
    const auto& h = in.header();
    const auto dw = h.dataWindow();
    // In 64 bits: a hostile window's corners overflow an int's difference.
    const int64_t w64 = int64_t(dw.max.x) - dw.min.x + 1, rows64 = int64_t(dw.max.y) - dw.min.y + 1;
    if (w64 > max_side || rows64 > max_side)
      throw Error(path.string() + ": " + std::to_string(w64) + "×" + std::to_string(rows64) + " pixels; at most " +
                  std::to_string(max_side) + " a side here (resample it first)");
    if (w64 < 1 || rows64 < 1) throw Error(path.string() + ": an empty EXR (its data window holds no pixel)");
    const int w = int(w64), rows = int(rows64);
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
