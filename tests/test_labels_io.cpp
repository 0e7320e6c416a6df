// Label encoding/decoding and file I/O: round trips, tolerant decoding of
// painted sketches, error paths.
#include <limits>
#include <csignal>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>


#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "reefgen/image_io.hpp"
#include "reefgen/io.hpp"
#include "reefgen/json_read.hpp"
#include "reefgen/labels.hpp"
#include "reefgen/preview.hpp"
#include "reefgen/rng.hpp"
#include "test_util.hpp"

using namespace reefgen;
using test::count_files;
using test::expect_error_naming;
using test::temp_dir;

namespace {

// Concentric regions, like a drawn island: abyss outside, island in the middle.
cv::Mat1b ring_labels(int W) {
  cv::Mat1b l(W, W);
  for (int y = 0; y < W; ++y)
    for (int x = 0; x < W; ++x) {
      const double r = std::hypot(x - W / 2.0 + 0.5, y - W / 2.0 + 0.5) / (W / 2.0);
      l(y, x) = static_cast<uint8_t>(std::min(4, static_cast<int>(r / 0.18)));
    }
  return l;
}

}  // namespace

TEST(Labels, ColoursFollowTheConvention) {
  EXPECT_EQ(region_rgb(kIsland, 0), cv::Vec3b(255, 255, 0));
  EXPECT_EQ(region_rgb(kBeach, 0), cv::Vec3b(0, 255, 0));
  EXPECT_EQ(region_rgb(kLagoon, 0), cv::Vec3b(0, 255, 255));
  EXPECT_EQ(region_rgb(kReef, 0), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(region_rgb(kAbyss, 0), cv::Vec3b(255, 0, 0));
  EXPECT_EQ(region_rgb(kIsland, 1), cv::Vec3b(64, 64, 0));  // V = 0.25 keeps the hue
}

TEST(Labels, EncodeDecodeRoundTrip) {
  const cv::Mat1b l = ring_labels(64);
  for (double lambda : {0.0, 0.3, 0.7, 1.0}) {
    const auto d = decode_sketch(encode_labels(l, lambda));
    EXPECT_EQ(cv::countNonZero(d.label != l), 0) << "lambda " << lambda;
    EXPECT_EQ(d.filled_px, 0);
    double mn, mx;
    cv::minMaxLoc(d.subsidence, &mn, &mx);
    EXPECT_NEAR(mn, lambda, 0.01);
    EXPECT_NEAR(mx, lambda, 0.01);
  }
}

TEST(Labels, PerPixelSubsidenceRoundTrip) {
  const cv::Mat1b l = ring_labels(32);
  cv::Mat1f lam(32, 32);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) lam(y, x) = x / 31.f;
  const auto d = decode_sketch(encode_labels(l, lam));
  EXPECT_EQ(cv::countNonZero(d.label != l), 0);
  EXPECT_LT(cv::norm(d.subsidence, lam, cv::NORM_INF), 0.01);
}

TEST(Labels, DecodesAPaintedNoisySketch) {
  // What an image editor produces: anti-aliased edges (blur), off-hue brush
  // colours, JPEG at quality 50, an alpha channel, 16 bits.
  const cv::Mat1b l = ring_labels(128);
  cv::Mat3b img = encode_labels(l, 0.2);
  Rng rng(1);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      for (int c = 0; c < 3; ++c)
        img(y, x)[c] = cv::saturate_cast<uint8_t>(img(y, x)[c] * 0.8 + 25 * rng.uniform());  // desaturated, noisy
  cv::GaussianBlur(img, img, {5, 5}, 1.2);
  std::vector<uchar> jpg;
  cv::imencode(".jpg", img, jpg, {cv::IMWRITE_JPEG_QUALITY, 50});
  cv::Mat noisy = cv::imdecode(jpg, cv::IMREAD_COLOR);
  cv::Mat bgra, deep;
  cv::cvtColor(noisy, bgra, cv::COLOR_BGR2BGRA);
  bgra.convertTo(deep, CV_16UC4, 257.0);
  const auto d = decode_sketch(deep);
  // Mislabelled pixels only along the 4 region borders (blur + JPEG), < 4 %.
  const double wrong = cv::countNonZero(d.label != l) / double(l.total());
  EXPECT_LT(wrong, 0.04);
  EXPECT_EQ(d.label(64, 64), kIsland);
  EXPECT_EQ(d.label(2, 2), kAbyss);
}

// The saturation is the per-region style: the palette's full colours are
// rugged (255) at every brightness, a pastel of the same hue is smooth (0)
// and keeps its region and subsidence; between, linear.
TEST(Labels, SaturationIsTheRuggedness) {
  cv::Mat1b l(4, 4, uint8_t(kIsland));
  l(0, 0) = kReef;
  const DecodedSketch full = decode_sketch(encode_labels(l, 0.6));
  EXPECT_EQ(cv::countNonZero(full.ruggedness != 255), 0);
  // Yellow at value 1: saturation 0.3 (smooth), 0.6 (half way), 1.0.
  auto yellow = [](double sat) {
    const uint8_t lo = uint8_t(std::lround(255 * (1 - sat)));
    return cv::Mat3b(2, 2, cv::Vec3b(lo, 255, 255));
  };
  const DecodedSketch pastel = decode_sketch(yellow(0.3));
  EXPECT_EQ(pastel.label(0, 0), kIsland);
  EXPECT_FLOAT_EQ(pastel.subsidence(0, 0), 0.f);
  EXPECT_EQ(pastel.ruggedness(0, 0), 0);
  EXPECT_NEAR(decode_sketch(yellow(0.6)).ruggedness(0, 0), 255 * (0.6 - kSmoothSaturation) /
                                                               (kRuggedSaturation - kSmoothSaturation), 1.0);
  EXPECT_EQ(decode_sketch(yellow(1.0)).ruggedness(0, 0), 255);
}

TEST(Labels, GreyPixelsTakeTheNearestRegionAndTransparentIsAbyss) {
  cv::Mat4b img(16, 16, cv::Vec4b(255, 0, 0, 255));  // blue reef everywhere (BGRA)
  img(8, 8) = cv::Vec4b(128, 128, 128, 255);          // a grey brush dot
  img(0, 0) = cv::Vec4b(0, 255, 0, 0);                // transparent
  const auto d = decode_sketch(img);
  EXPECT_EQ(d.label(8, 8), kReef);
  EXPECT_EQ(d.label(0, 0), kAbyss);
  EXPECT_EQ(d.filled_px, 1);
  // Hues between regions go to the nearest: orange (30°+ε) → island (60°).
  cv::Mat3b orange(4, 4, cv::Vec3b(0, 140, 255));
  EXPECT_EQ(decode_sketch(orange).label(0, 0), kIsland);
}

// A phone JPEG stores its pixels as the sensor saw them
// and says in EXIF how to turn them; the sketch is what the painter saw.
// A 40×20 JPEG, left half island yellow, EXIF orientation 6 (turn 90°
// clockwise): the sketch is 20×40 with the yellow half on top.
TEST(Labels, JpegSketchesFollowTheirExifOrientation) {
  cv::Mat3b img(20, 40, cv::Vec3b(0, 0, 255));
  img(cv::Rect(0, 0, 20, 20)).setTo(cv::Vec3b(0, 255, 255));
  std::vector<uchar> jpg;
  ASSERT_TRUE(cv::imencode(".jpg", img, jpg));
  // APP1 "Exif": a little-endian TIFF header and one IFD entry, Orientation
  // (tag 0x0112, SHORT, count 1) = 6.
  const uint8_t exif[] = {0xFF, 0xE1, 0x00, 0x22, 'E', 'x', 'i', 'f', 0, 0, 'I', 'I', 0x2A, 0x00, 8, 0, 0, 0,
                          1,    0,    0x12, 0x01, 3,   0,   1,   0,   0, 0, 6,   0,   0,    0,    0, 0, 0, 0};
  std::vector<uchar> file(jpg.begin(), jpg.begin() + 2);
  file.insert(file.end(), std::begin(exif), std::end(exif));
  file.insert(file.end(), jpg.begin() + 2, jpg.end());
  const auto dir = temp_dir("exif");
  write_file_atomic(dir / "phone.jpg", file.data(), file.size());
  const DecodedSketch s = read_sketch(dir / "phone.jpg");
  ASSERT_EQ(s.label.cols, 20);
  ASSERT_EQ(s.label.rows, 40);
  EXPECT_EQ(s.label(5, 10), kIsland) << "the yellow half is on top";
  EXPECT_EQ(s.label(35, 10), kAbyss);
  std::filesystem::remove_all(dir);
}

TEST(Labels, NoRegionColourIsAnError) {
  cv::Mat3b grey(8, 8, cv::Vec3b(100, 100, 100));
  EXPECT_THROW(decode_sketch(grey), Error);
  EXPECT_THROW(read_sketch("/nonexistent/sketch.png"), Error);
  const fs::path d = temp_dir("badimg");
  write_text_atomic(d / "corrupt.png", "this is not a PNG");
  expect_error_naming([&] { read_sketch(d / "corrupt.png"); }, "corrupt.png");
  fs::remove_all(d);
}

TEST(Io, ExrRoundTripWithAttributes) {
  const fs::path d = temp_dir("exr");
  cv::Mat1f h(24, 40);
  for (int y = 0; y < h.rows; ++y)
    for (int x = 0; x < h.cols; ++x) h(y, x) = -100.f + 3.25f * x + 0.5f * y;
  write_exr_height(d / "h.exr", h, {{"reefgen:test", "hello"}});
  ExrAttributes attrs;
  const cv::Mat1f back = read_exr_height(d / "h.exr", &attrs);
  EXPECT_EQ(back.size(), h.size());
  EXPECT_EQ(cv::norm(back, h, cv::NORM_INF), 0.0);
  EXPECT_EQ(attrs["reefgen:test"], "hello");
  EXPECT_EQ(count_files(d), 1);  // no temporary files left behind
  fs::remove_all(d);
}

TEST(Io, ExrRefusesNonFiniteHeights) {
  const fs::path d = temp_dir("nan");
  cv::Mat1f h(4, 4, 1.f);
  h(2, 1) = std::numeric_limits<float>::infinity();
  expect_error_naming([&] { write_exr_height(d / "h.exr", h); }, "NaN or infinite");
  h(2, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(write_exr_height(d / "h.exr", h), Error);
  EXPECT_EQ(count_files(d), 0);
  fs::remove_all(d);
}

TEST(Io, StagedOutputsAllOrNothing) {
  const fs::path d = temp_dir("staged");
  write_text_atomic(d / "a.txt", "old a");
  write_text_atomic(d / "b.txt", "old b");
  {  // a failure before commit: the old files stay, nothing new, no temporaries
    StagedOutputs s;
    s.write(d / "a.txt", [](const fs::path& t) { write_text_atomic(t, "new a"); });
    s.write(d / "c.txt", [](const fs::path& t) { write_text_atomic(t, "new c"); });
    expect_error_naming([&] { s.write(d / "b.txt", [](const fs::path&) { throw Error("disk full"); }); }, "disk full");
  }
  EXPECT_EQ(read_text(d / "a.txt"), "old a");
  EXPECT_EQ(read_text(d / "b.txt"), "old b");
  EXPECT_EQ(count_files(d), 2);
  {  // errors name the final file, not the temporary one
    StagedOutputs s;
    expect_error_naming([&] { s.write(d / "no" / "x.txt", [](const fs::path& t) { write_text_atomic(t, "x"); }); },
                        (d / "no" / "x.txt").string() + ":");
    fs::create_directories(d / "dir.txt");
    expect_error_naming([&] { s.write(d / "dir.txt", [](const fs::path& t) { write_text_atomic(t, "x"); }); },
                        "it is a folder");
    s.write(d / "a.txt", [](const fs::path& t) { write_text_atomic(t, "x"); });
    expect_error_naming([&] { s.write(d / "." / "a.txt", [](const fs::path& t) { write_text_atomic(t, "y"); }); },
                        "two outputs");
    fs::remove(d / "dir.txt");
  }
  EXPECT_EQ(read_text(d / "a.txt"), "old a");
  {  // commit replaces and adds, in one go
    StagedOutputs s;
    s.write(d / "a.txt", [](const fs::path& t) { write_text_atomic(t, "new a"); });
    s.write(d / "c.txt", [](const fs::path& t) { write_text_atomic(t, "new c"); });
    s.commit();
  }
  EXPECT_EQ(read_text(d / "a.txt"), "new a");
  EXPECT_EQ(read_text(d / "c.txt"), "new c");
  EXPECT_EQ(count_files(d), 3);
  fs::remove_all(d);
}

// A resumable run (a world): what a stopped run staged stays in the work
// folder, the next run with that folder does not write it again, and commit
// moves everything into place and removes the work folder; the old files are
// untouched until then.
TEST(Io, ResumableStagingKeepsFinishedFilesForTheNextRun) {
  const fs::path d = temp_dir("resumable"), work = d / "w.partial";
  write_text_atomic(d / "a.txt", "old a");
  int writes = 0;
  auto writer = [&](const std::string& text) {
    return [&writes, text](const fs::path& t) {
      ++writes;
      write_text_atomic(t, text);
    };
  };
  {  // stopped after a.txt and sub/b.txt were written
    StagedOutputs s(work, d);
    s.write(d / "a.txt", writer("new a"));
    s.write_all({{d / "sub" / "b.txt", writer("b")}}, 2);
    expect_error_naming([&] { s.write(d / "c.txt", [](const fs::path&) { throw Error("disk full"); }); }, "disk full");
  }
  EXPECT_EQ(read_text(d / "a.txt"), "old a");
  EXPECT_FALSE(fs::exists(d / "sub" / "b.txt"));
  EXPECT_EQ(writes, 2);
  {  // resumed: a and b are not written again, c is
    StagedOutputs s(work, d);
    EXPECT_TRUE(s.resumed(d / "a.txt"));
    EXPECT_FALSE(s.resumed(d / "c.txt"));
    s.write(d / "a.txt", writer("other a"));
    s.write_all({{d / "sub" / "b.txt", writer("other b")}, {d / "c.txt", writer("c")}}, 2);
    EXPECT_EQ(s.resumed_count(), 2u);
    s.commit();  // makes sub/ for b.txt
  }
  EXPECT_EQ(writes, 3);
  EXPECT_EQ(read_text(d / "a.txt"), "new a");
  EXPECT_EQ(read_text(d / "sub" / "b.txt"), "b");
  EXPECT_EQ(read_text(d / "c.txt"), "c");
  EXPECT_FALSE(fs::exists(work));
  StagedOutputs outside(work, d / "sub");
  expect_error_naming([&] { outside.write(d / "a.txt", writer("x")); }, "outside");
  fs::remove_all(d);
}

// Every format a sketch may come in declares its size in its header, and
// decode_image refuses a declared size past the limit before decoding: a
// PNG whose IHDR claims 30000² (its data is a few bytes) costs nothing.
TEST(Io, ImageSizesAreReadFromTheHeaderAndCheckedBeforeDecoding) {
  const cv::Mat img(37, 53, CV_8UC3, cv::Scalar(10, 200, 30));
  for (const char* ext : {".png", ".jpg", ".bmp", ".webp", ".tif", ".ppm"}) {
    std::vector<uchar> buf;
    ASSERT_TRUE(cv::imencode(ext, img, buf)) << ext;
    const std::string bytes(buf.begin(), buf.end());
    EXPECT_EQ(declared_image_size(bytes), cv::Size(53, 37)) << ext;
    expect_error_naming([&] { decode_image(bytes, std::string("s") + ext, cv::IMREAD_UNCHANGED, 50); }, "53×37 pixels; at most 50");
    EXPECT_EQ(decode_image(bytes, "s", cv::IMREAD_UNCHANGED, 53).cols, 53) << ext;
  }
  // A PNG whose header claims 30000² pixels.
  std::vector<uchar> buf;
  cv::imencode(".png", img, buf);
  std::string liar(buf.begin(), buf.end());
  for (int k = 0; k < 2; ++k) {
    const uint32_t v = 30000;
    for (int b = 0; b < 4; ++b) liar[size_t(16 + 4 * k + b)] = char((v >> (8 * (3 - b))) & 0xff);
  }
  EXPECT_EQ(declared_image_size(liar), cv::Size(30000, 30000));
  expect_error_naming([&] { decode_image(liar, "liar.png", cv::IMREAD_UNCHANGED, 4096); }, "30000×30000 pixels");
  EXPECT_EQ(declared_image_size("not an image"), cv::Size());
  // A PNM header with a comment; a format whose size is not read from a
  // header (here Radiance HDR) is refused before it is decoded.
  EXPECT_EQ(declared_image_size("P6\n# made by hand\n30000 20000\n255\n"), cv::Size(30000, 20000));
  cv::Mat hdr_img(8, 8, CV_32FC3, cv::Scalar(1, 1, 1));
  ASSERT_TRUE(cv::imencode(".hdr", hdr_img, buf));
  expect_error_naming([&] { decode_image(std::string(buf.begin(), buf.end()), "x.hdr", cv::IMREAD_UNCHANGED); },
                      "not an image reefgen can decode");
}

// A resumed run trusts only what it staged itself: a staged file truncated,
// altered, replaced by a link or without its record is written again.
TEST(Io, ResumableStagingRewritesWhatItCannotVouchFor) {
  const fs::path d = temp_dir("resume-verify"), work = d / "w.partial";
  write_text_atomic(d / "elsewhere.txt", "not ours");
  {
    StagedOutputs s(work, d);
    for (const char* n : {"a.txt", "b.txt", "c.txt", "d.txt", "e.txt"})
      s.write(d / n, [n](const fs::path& t) { write_text_atomic(t, std::string("first ") + n); });
  }  // stopped before commit
  write_text_atomic(work / "a.txt", "first");              // truncated
  write_text_atomic(work / "b.txt", "FIRST b.txt");        // altered, same size
  fs::remove(work / "c.txt");
  fs::create_symlink(d / "elsewhere.txt", work / "c.txt");  // a planted link
  fs::remove(work / "d.txt.sha256");                       // no record
  int writes = 0;
  StagedOutputs s(work, d);
  for (const char* n : {"a.txt", "b.txt", "c.txt", "d.txt", "e.txt"})
    s.write(d / n, [&writes, n](const fs::path& t) {
      ++writes;
      write_text_atomic(t, std::string("second ") + n);
    });
  s.commit();
  EXPECT_EQ(writes, 4);
  EXPECT_EQ(s.resumed_count(), 1u);
  for (const char* n : {"a.txt", "b.txt", "c.txt", "d.txt"}) EXPECT_EQ(read_text(d / n), std::string("second ") + n);
  EXPECT_EQ(read_text(d / "e.txt"), "first e.txt");
  EXPECT_FALSE(fs::is_symlink(d / "c.txt"));
  EXPECT_EQ(read_text(d / "elsewhere.txt"), "not ours");
  fs::remove_all(d);
}

// A name that fits the filesystem (255 bytes) is written,
// although NAME.tmp.PID.N would not fit; its temporary name is cut short.
TEST(Io, LongestNamesAreWrittenThroughAShortenedTemporary) {
  const auto dir = temp_dir("longname");
  for (const size_t len : {size_t(240), size_t(255)}) {
    const std::string name = std::string(len - 11, 'n') + ".height.exr";
    ASSERT_EQ(name.size(), len);
    const std::string bytes = "island " + std::to_string(len);
    write_file_atomic(dir / name, bytes.data(), bytes.size());
    EXPECT_EQ(read_text(dir / name), bytes);
  }
  EXPECT_EQ(count_files(dir), 2) << "no temporary file left";
  std::filesystem::remove_all(dir);
}

// A rename that fails says why ("rename failed (Success)"
// came from reporting the clean-up's error code instead of the rename's).
TEST(Io, AFailedRenameSaysWhy) {
  const auto dir = temp_dir("rename");
  std::filesystem::create_directories(dir / "taken" / "inside");
  try {
    write_file_atomic(dir / "taken", "x", 1);
    ADD_FAILURE() << "no error for a destination that is a non-empty folder";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("taken"), std::string::npos) << m;
    EXPECT_EQ(m.find("Success"), std::string::npos) << m;
  }
  EXPECT_EQ(count_files(dir), 1) << "only the folder: the temporary is gone";
  std::filesystem::remove_all(dir);
}

TEST(Io, WritesToAnUnwritableFolderFailCleanly) {
  // A regular file where a folder is expected: fails even for root, unlike
  // permission bits.
  const fs::path d = temp_dir("ro");
  write_text_atomic(d / "file", "x");
  expect_error_naming([&] { write_text_atomic(d / "file" / "x.json", "{}"); }, "file/x.json");
  EXPECT_THROW(write_exr_height(d / "file" / "h.exr", cv::Mat1f(4, 4, 0.f)), Error);
  EXPECT_THROW(ensure_writable_dir(d / "file" / "sub"), Error);
  EXPECT_EQ(count_files(d), 1);  // nothing but the file itself: no temporaries left
  fs::remove_all(d);
}

TEST(Io, MissingFolderAndBadJsonAreErrors) {
  EXPECT_THROW(write_text_atomic("/nonexistent-folder/x.json", "{}"), Error);
  EXPECT_THROW(read_json("/nonexistent-folder/x.json"), Error);
  const fs::path d = temp_dir("json");
  write_text_atomic(d / "bad.json", "{\"a\": ");
  expect_error_naming([&] { read_json(d / "bad.json"); }, "bad.json");
  fs::remove_all(d);
}

TEST(Preview, CoastlineIsDrawnAndWaterIsBlue) {
  cv::Mat1f h(32, 32, -50.f);
  cv::circle(h, {16, 16}, 8, cv::Scalar(100.f), -1);
  const cv::Mat3b p = render_preview(h);
  const cv::Vec3b water = p(1, 1), land = p(16, 16), coast = p(16, 8);
  EXPECT_GT(water[0], water[2]);  // BGR: blue dominates
  EXPECT_GT(land[1], land[0]);    // land is not blue
  EXPECT_LT(coast[0] + coast[1] + coast[2], 200);  // dark line at 0 m
}

TEST(Rng, ReproducibleAndIndependentStreams) {
  Rng a(5, 1, "x"), b(5, 1, "x"), c(5, 2, "x"), d(5, 1, "y");
  const uint64_t va = a.next_u64();
  EXPECT_EQ(va, b.next_u64());
  EXPECT_NE(va, c.next_u64());
  EXPECT_NE(va, d.next_u64());
  Rng u(11);
  double sum = 0;
  for (int i = 0; i < 100000; ++i) {
    const double x = u.uniform();
    ASSERT_GE(x, 0.0);
    ASSERT_LT(x, 1.0);
    sum += x;
  }
  EXPECT_NEAR(sum / 100000, 0.5, 0.005);
}

TEST(Io, AtomicTextWriterCommitsOrLeavesNothing) {
  const fs::path d = temp_dir("atw");
  {
    AtomicTextWriter w(d / "kept.txt");
    w.write("a\n");
    w.write("b\n");
    EXPECT_FALSE(fs::exists(d / "kept.txt"));  // not under the final name before commit
    w.commit();
  }
  EXPECT_EQ(read_text(d / "kept.txt"), "a\nb\n");
  {
    AtomicTextWriter w(d / "dropped.txt");
    w.write("half");
  }  // an exception or an interrupt: no commit
  EXPECT_EQ(count_files(d), 1);
  expect_error_naming([&] { AtomicTextWriter w(d / "no" / "such" / "x.txt"); }, "x.txt");
  fs::remove_all(d);
}

TEST(Io, OwnPngEncoderRoundTripsThroughOpenCV) {
  const fs::path d = temp_dir("png8");
  Rng rng(5);
  cv::Mat3b rgb(37, 53);
  cv::Mat1b grey(19, 7);
  for (auto& p : rgb) p = cv::Vec3b(uint8_t(rng.uniform_int(0, 255)), uint8_t(rng.uniform_int(0, 255)), uint8_t(rng.uniform_int(0, 255)));
  for (auto& p : grey) p = uint8_t(rng.uniform_int(0, 255));
  for (int level : {1, 6, 9}) {
    write_png(d / "rgb.png", rgb, level);
    write_png(d / "grey.png", grey, level);
    const cv::Mat a = cv::imread((d / "rgb.png").string(), cv::IMREAD_UNCHANGED);
    const cv::Mat b = cv::imread((d / "grey.png").string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(a.type(), CV_8UC3);
    ASSERT_EQ(b.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(a, rgb, cv::NORM_INF), 0.0) << "level " << level;
    EXPECT_EQ(cv::norm(b, grey, cv::NORM_INF), 0.0) << "level " << level;
  }
  // A label map (runs of one colour) compresses well with Sub + RLE.
  const cv::Mat3b flat = encode_labels(ring_labels(256), 0.3);
  write_png(d / "labels.png", flat, 1);
  EXPECT_LT(fs::file_size(d / "labels.png"), 8000u);
  fs::remove_all(d);
}

// A cut download or a damaged chunk is an error naming the file,
// decided before OpenCV sees it (libpng would print to stderr and OpenCV
// return a half-grey image for a truncated JPEG).
TEST(Io, TruncatedAndDamagedImagesAreRefused) {
  const fs::path dir = test::temp_dir("images");
  cv::Mat3b img(64, 64, cv::Vec3b(40, 200, 90));
  cv::circle(img, {32, 32}, 20, cv::Scalar(0, 0, 255), -1);
  std::vector<uchar> png, jpg;
  cv::imencode(".png", img, png);
  cv::imencode(".jpg", img, jpg);
  const std::string p(png.begin(), png.end()), j(jpg.begin(), jpg.end());
  EXPECT_EQ(image_damage(p), "");
  EXPECT_EQ(image_damage(j), "");
  EXPECT_EQ(image_damage(j + std::string(3, '\0')), "") << "zero padding after the end marker is fine";
  EXPECT_NE(image_damage(p.substr(0, p.size() - 12)).find("no IEND"), std::string::npos);
  EXPECT_NE(image_damage(p.substr(0, 60)).find("truncated PNG"), std::string::npos);
  std::string flipped = p;
  flipped[40] = char(flipped[40] ^ 0x10);  // inside IHDR or IDAT: its CRC no longer matches
  EXPECT_NE(image_damage(flipped).find("CRC"), std::string::npos);
  EXPECT_NE(image_damage(j.substr(0, j.size() / 2)).find("truncated JPEG"), std::string::npos);
  // Through the file reader: the error names the file; a whole file decodes.
  write_file_atomic(dir / "cut.jpg", j.data(), j.size() / 2);
  test::expect_error_naming([&] { read_image(dir / "cut.jpg", cv::IMREAD_COLOR); }, (dir / "cut.jpg").string());
  test::expect_error_naming([&] { read_sketch(dir / "cut.jpg"); }, "truncated JPEG");
  test::expect_error_naming([&] { read_image(dir / "missing.png", cv::IMREAD_COLOR); }, "no such file");
  test::expect_error_naming([&] { read_image(dir, cv::IMREAD_COLOR); }, "folder");
  write_file_atomic(dir / "ok.png", p.data(), p.size());
  const cv::Mat back = read_image(dir / "ok.png", cv::IMREAD_COLOR);
  EXPECT_EQ(cv::norm(back, img, cv::NORM_INF), 0);
  fs::remove_all(dir);
}

// Config reads are bounded and name what is wrong.
TEST(Io, JsonReadsAreBoundedAndRefuseFolders) {
  const fs::path dir = test::temp_dir("json");
  test::expect_error_naming([&] { read_json(dir); }, "is a folder");
  test::expect_error_naming([&] { read_json("/dev/zero"); }, "larger than 16 MiB");
  test::expect_error_naming([&] { read_json(dir / "none.json"); }, "no such file");
  fs::remove_all(dir);
}

// Library type errors name the field and the value (was "type_error.302").
TEST(Io, JsonTypeErrorsNameTheField) {
  double d = 0;
  bool b = false;
  std::string s;
  test::expect_error_naming([&] { read_json_value(nlohmann::json("fast"), d, "train.json: lr"); },
                            "train.json: lr = \"fast\" must be a number");
  test::expect_error_naming([&] { read_json_value(nlohmann::json(1), b, "x: flip"); }, "x: flip = 1 must be true or false");
  test::expect_error_naming([&] { read_json_value(nlohmann::json(2.5), s, "x: norm"); }, "x: norm = 2.5 must be a string");
  // Whole numbers at the edges of their type: 2^64 (parsed as a double,
  // which rounds uint64's max up to it) became seed 0; 2^64 - 1 is a seed.
  uint64_t seed = 7;
  test::expect_error_naming(
      [&] { read_json_value(nlohmann::json::parse("18446744073709551616"), seed, "spec.json: noise.seed"); },
      "spec.json: noise.seed = 1.8446744073709552e+19 is out of range");
  EXPECT_EQ(seed, 7u);
  read_json_value(nlohmann::json::parse("18446744073709551615"), seed, "s");
  EXPECT_EQ(seed, UINT64_MAX);
  int64_t i = 0;
  test::expect_error_naming([&] { read_json_value(nlohmann::json(9223372036854775808.0), i, "x: n"); }, "out of range");
  read_json_value(nlohmann::json(-9223372036854775808.0), i, "x: n");
  EXPECT_EQ(i, INT64_MIN);
}

// SIGTERM, SIGHUP or SIGINT (Ctrl-C) while an output is staged, or while a
// streamed file (AtomicTextWriter: a dataset's manifest; it was left behind
// by a Ctrl-C'd dataset build) is open, leaves no *.tmp.* file once
// remove_temps_on_fatal_signals is
// installed (reefgen's main does); without it the temporary file stays,
// which is what the test would see if the handler did nothing.
TEST(Io, FatalSignalsRemoveStagedTemporaryFiles) {
  for (bool handled : {true, false}) {
    for (int sig : {SIGTERM, SIGHUP, SIGINT}) {
      const fs::path dir = fs::temp_directory_path() / ("reefgen_sigtmp_" + std::to_string(::getpid()) + "_" +
                                                        std::to_string(sig) + (handled ? "h" : "u"));
      fs::remove_all(dir);
      fs::create_directories(dir);
      const pid_t child = ::fork();
      ASSERT_GE(child, 0);
      if (child == 0) {
        if (handled) remove_temps_on_fatal_signals();
        // A streamed file open for the whole run (a dataset's manifest) and a staged one.
        AtomicTextWriter manifest(dir / "manifest.jsonl");
        manifest.write("{\"index\": 0}\n");
        // More short-lived files than the handler's table has slots (256),
        // as a dataset writes pairs: the manifest must keep its slot.
        for (int i = 0; i < 300; ++i) write_text_atomic(dir / ("pair" + std::to_string(i) + ".txt"), "pair");
        StagedOutputs out;
        out.write(dir / "island.height.exr", [&](const fs::path& tmp) {
          write_text_atomic(dir / "done.txt", "staged");  // committed: must stay
          std::FILE* f = std::fopen(tmp.c_str(), "wb");
          std::fputs("half a file", f);
          std::fclose(f);
          ::raise(sig);
        });
        ::_exit(0);
      }
      int status = 0;
      ::waitpid(child, &status, 0);
      ASSERT_TRUE(WIFSIGNALED(status)) << "the child was not ended by the signal";
      EXPECT_EQ(WTERMSIG(status), sig);
      int temps = 0;
      for (const auto& e : fs::directory_iterator(dir)) temps += e.path().string().find(".tmp.") != std::string::npos;
      EXPECT_TRUE(fs::exists(dir / "done.txt"));
      EXPECT_EQ(temps, handled ? 0 : 2) << "signal " << sig << (handled ? " with" : " without") << " the handler";
      fs::remove_all(dir);
    }
  }
}
