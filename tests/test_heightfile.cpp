// The height-field files terrain tools import (common/heightfile.hpp: PNG16,
// R16, grid meshes, the staged writer and its sidecar), SHA-256 and the median, read back
// without LibTorch: this binary links only reefgen_common.
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>

#include <gtest/gtest.h>

#include "reefgen/normal.hpp"
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "reefgen/error.hpp"
#include "reefgen/files.hpp"
#include "reefgen/heightfile.hpp"
#include "reefgen/image_io.hpp"
#include "reefgen/sha256.hpp"
#include "reefgen/stats.hpp"
#include "test_util.hpp"

using namespace reefgen;
using test::expect_error_naming;
using test::bumpy;
using test::temp_dir;

namespace {

uint32_t u32_at(const std::string& b, size_t off) {
  uint32_t v = 0;
  for (int k = 3; k >= 0; --k) v = (v << 8) | uint8_t(b[off + size_t(k)]);
  return v;
}

}  // namespace

TEST(Export, Png16AndR16RoundTrip) {
  const fs::path d = temp_dir("png16");
  const cv::Mat1f h = bumpy(64);
  write_png16(d / "h.png", h, -100, 560);
  const cv::Mat1f back = read_png16(d / "h.png", -100, 560);
  EXPECT_LE(cv::norm(back, h, cv::NORM_INF), 660.0 / 65535 / 2 + 1e-4);  // half a quantisation step
  write_r16(d / "h.r16", h, -100, 560);
  const std::string raw = test::file_bytes(d / "h.r16");
  ASSERT_EQ(raw.size(), 64u * 64u * 2u);
  // Little-endian, row 0 first, same values as the PNG.
  const cv::Mat png = cv::imread((d / "h.png").string(), cv::IMREAD_UNCHANGED);
  for (int k : {0, 1, 64, 64 * 20 + 30, 64 * 64 - 1})
    EXPECT_EQ(uint16_t(uint8_t(raw[2 * size_t(k)]) | (uint8_t(raw[2 * size_t(k) + 1]) << 8)), png.at<uint16_t>(k / 64, k % 64));
  // Unity takes square 2^n+1 heightmaps only; its steps say to flip the rows
  // (Unity's row 0 is south) and span (N − 1) cells.
  EXPECT_NE(r16_import_note(64, 64, -100, 560, 10).find("Unity cannot import this file"), std::string::npos);
  const std::string unity = r16_import_note(65, 65, -100, 560, 10);
  EXPECT_NE(unity.find("Width 65"), std::string::npos);
  EXPECT_NE(unity.find("Flip Vertically on"), std::string::npos);
  EXPECT_NE(unity.find("Terrain Size x = z = 640 m"), std::string::npos);
  fs::remove_all(d);
}

// A field beyond the model's nominal range (a 608 m peak,
// a −130 m trench) is exported without clipping, and the sidecar's engine
// numbers follow from the range.
TEST(Export, SixteenBitFilesSpanTheFieldsOwnRange) {
  const fs::path d = temp_dir("range");
  cv::Mat1f h = bumpy(64);
  h(10, 10) = 608.4f;
  h(50, 50) = -130.2f;
  const HeightRange r = export_range(h);
  EXPECT_EQ(r.lo_m, -131.0);
  EXPECT_EQ(r.hi_m, 609.0);
  write_png16(d / "h.png", h, r.lo_m, r.hi_m);
  const cv::Mat1f back = read_png16(d / "h.png", r.lo_m, r.hi_m);
  const double step = (r.hi_m - r.lo_m) / 65535;
  EXPECT_LE(cv::norm(back, h, cv::NORM_INF), step / 2 + 1e-3) << "the peak and the trench survive";
  EXPECT_NEAR(back(10, 10), 608.4, step);
  const nlohmann::json j = nlohmann::json::parse(engine_import_json(64, 64, r, 10.0));
  EXPECT_NEAR(j["unreal"]["scale_z_percent"].get<double>(), 740.0 * 100 / 512, 1e-9);
  EXPECT_NEAR(j["unreal"]["location_z_cm"].get<double>(), (609.0 - 131.0) / 2 * 100, 1e-9);
  EXPECT_NEAR(j["unreal"]["scale_xy_cm"].get<double>(), 1000.0, 1e-9);
  EXPECT_NEAR(j["unity"]["terrain_height_m"].get<double>(), 740.0, 1e-9);
  EXPECT_NEAR(j["unity"]["position_y_m"].get<double>(), -131.0, 1e-9);
  EXPECT_NEAR(j["blender"]["displace_midlevel"].get<double>(), 131.0 / 740.0, 1e-12);
  // A flat field still gets a 1 m span (no division by zero in the encoders).
  const HeightRange flat = export_range(cv::Mat1f(8, 8, 3.5f));
  EXPECT_EQ(flat.hi_m - flat.lo_m, 1.0);
  cv::Mat1f nan = h.clone();
  nan(3, 3) = NAN;
  expect_error_naming([&] { export_range(nan); }, "NaN");
  fs::remove_all(d);
}

// One writer for infer, terrain and the studio: every requested file, named
// from the prefix, nothing in place before commit, the sidecar naming them
// with the range the 16-bit files really use.
TEST(Export, StageHeightFilesWritesWhatWasAskedOnCommit) {
  const fs::path d = temp_dir("stage");
  cv::Mat1f h = bumpy(64);
  h(5, 5) = 612.f;  // above the model's nominal range: must not clip
  HeightFiles f;
  f.png16 = f.r16 = f.preview = true;
  f.mesh = "glb";
  f.exr_attributes = {{"reefgen:seed", "7"}};
  nlohmann::json side;
  {
    StagedOutputs staged;
    side = stage_height_files(staged, d / "isl", h, 25.0, f);
    EXPECT_FALSE(fs::exists(d / "isl.height.exr"));  // staged, not yet in place
    staged.commit();
  }
  for (const char* suffix : {".height.exr", ".height.png", ".r16", ".glb", ".preview.png"})
    EXPECT_TRUE(fs::is_regular_file(d / ("isl" + std::string(suffix)))) << suffix;
  EXPECT_EQ(side["files"].size(), 7u);  // EXR, PNG16 + VRT, R16 + VRT, mesh, preview
  EXPECT_EQ(side["files"]["height_r16"], "isl.r16");
  const double lo = side["png16"]["lo_m"], hi = side["png16"]["hi_m"];
  EXPECT_GE(hi, 612.0);
  EXPECT_LE(cv::norm(read_png16(d / "isl.height.png", lo, hi), h, cv::NORM_INF), (hi - lo) / 65535 / 2 + 1e-3);
  EXPECT_EQ(side["r16"]["lo_m"], lo);
  EXPECT_NE(side["r16"]["import_note"].get<std::string>().find("resolution 64x64"), std::string::npos);
  EXPECT_EQ(side["files"]["height_r16_vrt"], "isl.r16.vrt");
  const std::string vrt = read_text(d / "isl.r16.vrt");
  EXPECT_NE(vrt.find("<Offset>" ), std::string::npos);
  EXPECT_NE(vrt.find("isl.r16</SourceFilename>"), std::string::npos);
  ExrAttributes attrs;
  (void)read_exr_height(d / "isl.height.exr", &attrs);
  EXPECT_EQ(attrs["reefgen:seed"], "7");
  EXPECT_EQ(std::stod(attrs["reefgen:metres_per_pixel"]), 25.0);
  // Only what is asked: the EXR alone, and a bad mesh format refused by name.
  HeightFiles only;
  {
    StagedOutputs staged;
    EXPECT_EQ(stage_height_files(staged, d / "one", h, 25.0, only)["files"].size(), 1u);
    staged.commit();
  }
  EXPECT_FALSE(fs::exists(d / "one.height.png"));
  only.mesh = "fbx";
  StagedOutputs staged;
  test::expect_error_naming([&] { stage_height_files(staged, d / "bad", h, 25.0, only); }, "fbx");
  fs::remove_all(d);
}

TEST(Export, ObjReadsBack) {
  const fs::path d = temp_dir("obj");
  const cv::Mat1f h = bumpy(16);
  write_obj(d / "m.obj", h, {10.0, 2.0});
  std::ifstream f(d / "m.obj");
  std::string tag, line;
  std::vector<cv::Vec3f> v;
  std::vector<cv::Vec2f> vt;
  int faces = 0;
  while (f >> tag) {
    if (tag == "v") {
      cv::Vec3f p;
      f >> p[0] >> p[1] >> p[2];
      v.push_back(p);
    } else if (tag == "f") {  // "f a/a b/b c/c": vertex / texture coordinate
      std::string ta, tb, tc;
      f >> ta >> tb >> tc;
      const long a = std::stol(ta), b = std::stol(tb), c = std::stol(tc);
      EXPECT_TRUE(a >= 1 && b >= 1 && c >= 1 && a <= 256 && b <= 256 && c <= 256);
      ++faces;
    } else if (tag == "vt") {
      cv::Vec2f t;
      f >> t[0] >> t[1];
      vt.push_back(t);
    } else {
      std::getline(f, line);
    }
  }
  ASSERT_EQ(v.size(), 256u);
  ASSERT_EQ(vt.size(), 256u);
  EXPECT_NEAR(vt[5 * 16 + 7][0], 7.5 / 16, 1e-4);  // the canvas drapes on: u along columns,
  EXPECT_NEAR(vt[5 * 16 + 7][1], 1 - 5.5 / 16, 1e-4);  // OBJ's v up
  EXPECT_EQ(faces, 15 * 15 * 2);
  EXPECT_NEAR(v[5 * 16 + 7][1], 2.0 * h(5, 7), 1e-2);  // exaggerated height, +Y up
  EXPECT_NEAR(v[1][0] - v[0][0], 10.0, 1e-3);          // spacing in metres
  EXPECT_NEAR(v[0][0] + v[15][0], 0.0, 1e-3);          // centred
  expect_error_naming([&] { write_obj(d / "x.obj", h, {10.0, 0.0}); }, "exaggeration");
  fs::remove_all(d);
}

TEST(Export, GlbReadsBack) {
  const fs::path d = temp_dir("glb");
  const cv::Mat1f h = bumpy(16);
  write_glb(d / "m.glb", h, {10.0, 1.0});
  const std::string b = test::file_bytes(d / "m.glb");
  ASSERT_GE(b.size(), 20u);
  EXPECT_EQ(b.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(b, 4), 2u);
  EXPECT_EQ(u32_at(b, 8), b.size());
  const uint32_t json_len = u32_at(b, 12);
  EXPECT_EQ(b.substr(16, 4), "JSON");
  const auto j = nlohmann::json::parse(b.substr(20, json_len));
  const size_t bin_at = 20 + json_len;
  EXPECT_EQ(b.substr(bin_at + 4, 4), std::string("BIN\0", 4));
  const uint32_t bin_len = u32_at(b, bin_at);
  EXPECT_EQ(bin_len, j["buffers"][0]["byteLength"].get<uint32_t>());
  EXPECT_EQ(bin_at + 8 + bin_len, b.size());
  const auto& prim = j["meshes"][0]["primitives"][0];
  const auto& acc = j["accessors"];
  const int pos = prim["attributes"]["POSITION"], idx = prim["indices"], uv = prim["attributes"]["TEXCOORD_0"];
  EXPECT_EQ(acc[pos]["count"], 256);
  EXPECT_EQ(acc[idx]["count"], 15 * 15 * 6);
  auto at = [&](int accessor) { return bin_at + 8 + j["bufferViews"][acc[accessor]["bufferView"].get<int>()]["byteOffset"].get<size_t>(); };
  // Vertex (5, 7): its y is the height, its uv the pixel centre on the canvas.
  float p[3], t[2];
  std::memcpy(p, b.data() + at(pos) + (5 * 16 + 7) * 12, 12);
  EXPECT_FLOAT_EQ(p[1], h(5, 7));
  std::memcpy(t, b.data() + at(uv) + (5 * 16 + 7) * 8, 8);
  EXPECT_FLOAT_EQ(t[0], 7.5f / 16);
  EXPECT_FLOAT_EQ(t[1], 5.5f / 16);
  // Indices in range, every triangle facing up (+Y normal).
  const size_t idx_off = at(idx);
  for (int t = 0; t < 15 * 15 * 2; ++t) {
    uint32_t ix[3];
    std::memcpy(ix, b.data() + idx_off + size_t(t) * 12, 12);
    cv::Vec3f q[3];
    for (int k = 0; k < 3; ++k) {
      ASSERT_LT(ix[k], 256u);
      float xyz[3];
      std::memcpy(xyz, b.data() + at(pos) + ix[k] * 12, 12);
      q[k] = cv::Vec3f(xyz[0], xyz[1], xyz[2]);
    }
    EXPECT_GT((q[1] - q[0]).cross(q[2] - q[0])[1], 0.f) << "triangle " << t;
  }
  fs::remove_all(d);
}

TEST(Sha256, KnownVectors) {  // FIPS 180-4 examples
  EXPECT_EQ(sha256_hex("", 0), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc", 3), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  const std::string two_blocks = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
  EXPECT_EQ(sha256_hex(two_blocks.data(), two_blocks.size()),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  Sha256 million;  // fed in uneven pieces across block boundaries
  const std::string a(999, 'a');
  for (int i = 0; i < 1001; ++i) million.update(a.data(), a.size());  // 999 999 bytes
  million.update("a", 1);
  EXPECT_EQ(million.hex(), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}


TEST(Stats, MedianOfOddEvenAndEmpty) {
  EXPECT_EQ(median({3, 1, 2}), 2.0);
  EXPECT_EQ(median({0.31, 0, 0.286, 0.5}), (0.286 + 0.31) / 2);  // the two middle values' mean
  EXPECT_TRUE(std::isnan(median({})));
}

namespace {
// The rename before which the child of CommitCutShortIsFinished "is killed".
size_t g_kill_before = 0;
void exit_at_cut(size_t renamed) {
  if (renamed == g_kill_before) ::_exit(9);
}
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
}  // namespace

// A commit of five files killed between two renames (a child process that
// _exits there) leaves a mix of two runs on disk, and its journal; the next
// sweep of the folder finishes the renames: the new set, whole. Killed
// before the commit, the old set stays and the staged copies go.
TEST(StagedOutputs, ACommitCutShortIsFinishedByTheNextSweep) {
  const fs::path dir = temp_dir("commit_cut");
  const std::vector<std::string> names = {"x.height.exr", "x.label.png", "x.r16", "x.preview.png", "x.json"};
  const auto write_set = [&](const std::string& text) {
    for (const auto& n : names) write_text_atomic(dir / n, text);
  };
  const auto count_of = [&](const std::string& text) {
    int k = 0;
    for (const auto& n : names) k += slurp(dir / n) == text;
    return k;
  };
  const auto leftovers = [&] {
    int k = 0;
    for (const auto& e : fs::directory_iterator(dir)) {
      const std::string n = e.path().filename().string();
      k += n.find(".tmp.") != std::string::npos || n.rfind(kCommitJournalPrefix, 0) == 0;
    }
    return k;
  };
  const auto run_child = [&](bool commit) {
    const pid_t child = ::fork();
    if (child == 0) {
      detail::commit_pause_for_tests = exit_at_cut;
      StagedOutputs s;
      for (const auto& n : names)
        s.write(dir / n, [](const fs::path& p) { write_text_atomic(p, "new"); });
      if (commit) s.commit();
      ::_exit(0);
    }
    int status = 0;
    ::waitpid(child, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  for (size_t cut : {size_t(1), size_t(3), size_t(4)}) {
    write_set("old");
    g_kill_before = cut;
    ASSERT_EQ(run_child(true), 9) << cut;
    EXPECT_EQ(count_of("new"), int(cut)) << "before the sweep: a mix of " << cut << " new files";
    EXPECT_GT(leftovers(), 0);
    remove_stale_temps(dir);
    EXPECT_EQ(count_of("new"), int(names.size())) << "cut before rename " << cut;
    EXPECT_EQ(leftovers(), 0) << "journal and staged copies gone";
  }
  write_set("old");
  g_kill_before = 99;
  ASSERT_EQ(run_child(false), 0);
  EXPECT_GT(leftovers(), 0);
  remove_stale_temps(dir);
  EXPECT_EQ(count_of("old"), int(names.size()));
  EXPECT_EQ(leftovers(), 0);
  // A journal of a live process (this one) is not touched.
  write_text_atomic(dir / (std::string(kCommitJournalPrefix) + std::to_string(::getpid()) + ".0"),
                    std::string(kCommitJournalHeader) + "\n");
  EXPECT_EQ(finish_interrupted_commits(dir), 0);
}

// A journal is obeyed only for renames a commit of ours would make: a
// planted one (a dead process's name) cannot move a user's file over another
// in the folder, reach outside the folder (by path or through "..") or be a
// link; a real journal reached through a link to the folder still finishes.
TEST(StagedOutputs, APlantedJournalMovesNoUserFile) {
  const fs::path root = temp_dir("journal_planted");
  const fs::path dir = root / "out", outside = root / "elsewhere";
  fs::create_directories(dir);
  fs::create_directories(outside);
  write_text_atomic(dir / "notes.txt", "mine");
  write_text_atomic(dir / "thesis.txt", "precious");
  write_text_atomic(outside / "keys.txt", "secret");
  write_text_atomic(outside / "x.tmp.1.0", "staged elsewhere");
  // A dead process's id: a child that has exited and been reaped.
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  ::waitpid(dead, nullptr, 0);
  const std::string journal = std::string(kCommitJournalPrefix) + std::to_string(dead) + ".";
  const auto plant = [&](const std::string& n, const fs::path& from, const fs::path& to) {
    write_text_atomic(dir / (journal + n), std::string(kCommitJournalHeader) + "\n" + fs::absolute(from).string() +
                                               "\t" + fs::absolute(to).string() + "\n");
  };
  plant("0", dir / "notes.txt", dir / "thesis.txt");           // not a staged copy
  plant("1", dir / "thesis.txt", outside / "keys.txt");         // outside the folder
  plant("2", outside / "x.tmp.1.0", dir / "thesis.txt");        // a source outside
  plant("3", dir / ".." / "elsewhere" / "x.tmp.1.0", dir / "y");  // out through ".."
  fs::create_symlink(fs::absolute(dir / (journal + "0")), dir / (journal + "9"));
  EXPECT_EQ(finish_interrupted_commits(dir), 4) << "the planted journals are cleared, the link is not followed";
  EXPECT_EQ(slurp(dir / "notes.txt"), "mine");
  EXPECT_EQ(slurp(dir / "thesis.txt"), "precious");
  EXPECT_EQ(slurp(outside / "keys.txt"), "secret");
  EXPECT_EQ(slurp(outside / "x.tmp.1.0"), "staged elsewhere");
  EXPECT_FALSE(fs::exists(dir / "y"));
  // A real journal's rename, the folder reached through a link: finished.
  fs::remove(dir / (journal + "9"));
  write_text_atomic(dir / "z.tmp.1.0", "new");
  plant("4", dir / "z.tmp.1.0", dir / "z.txt");
  fs::create_directory_symlink(fs::absolute(dir), root / "link");
  EXPECT_EQ(finish_interrupted_commits(root / "link"), 1);
  EXPECT_EQ(slurp(dir / "z.txt"), "new");
}

// Φ⁻¹ round-trips over the whole range a blurred mask takes, the tails
// included: plain Newton from its logistic start diverged at m = 0.00121
// (−1.2e12; a painted coast's shoreface fell away there, leaving a trench a
// model cell wide). Known values: Φ⁻¹(0.975) = 1.959964, Φ⁻¹(0.5) = 0.
TEST(Normal, QuantileRoundTripsIntoTheTails) {
  EXPECT_NEAR(reefgen::normal_quantile(0.975), 1.959963985, 1e-8);
  EXPECT_NEAR(reefgen::normal_quantile(0.5), 0.0, 1e-12);
  EXPECT_NEAR(reefgen::normal_quantile(0.00121), -3.03317, 1e-4);
  for (double e = -12; e <= -1e-3; e += 0.01) {
    const double m = std::pow(10.0, e);
    for (const double v : {m, 1 - m}) {
      if (!(v > 0 && v < 1)) continue;
      const double x = reefgen::normal_quantile(v);
      ASSERT_TRUE(std::isfinite(x)) << v;
      ASSERT_NEAR(reefgen::normal_cdf(x) / v, 1.0, 1e-6) << v;
    }
  }
}

// JSON guards nlohmann's parser lacks: a nesting past kMaxJsonDepth (100,000
// nested arrays overflowed the stack) and a key repeated in one object are
// refused in one line naming the file; a nesting at the limit and the same
// key in two objects are fine.
TEST(Json, DeepNestingAndRepeatedKeysAreRefusedNamingTheFile) {
  const fs::path d = temp_dir("json-guards");
  auto nested = [](int depth) { return "{\"a\": " + std::string(size_t(depth), '[') + std::string(size_t(depth), ']') + "}"; };
  { std::ofstream(d / "deep.json") << nested(100000); }
  { std::ofstream(d / "dup.json") << "{\"subsidence\": 0.2, \"heights\": {\"peak_m\": 1}, \"subsidence\": 0.5}"; }
  { std::ofstream(d / "ok.json") << "{\"a\": {\"x\": 1}, \"b\": {\"x\": 2}}"; }
  for (const char* name : {"deep.json", "dup.json"}) {
    try {
      reefgen::read_json(d / name);
      ADD_FAILURE() << name << " was accepted";
    } catch (const reefgen::Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(reefgen::read_json(d / "ok.json")["b"]["x"], 2);
  EXPECT_NO_THROW(reefgen::parse_json_checked(nested(reefgen::kMaxJsonDepth - 1), "limit"));
  EXPECT_THROW(reefgen::parse_json_checked(nested(reefgen::kMaxJsonDepth + 1), "past"), reefgen::Error);
  fs::remove_all(d);
}
