// Runs a libFuzzer target over the files of its corpus folders, without
// libFuzzer: the regression test of the fuzzing corpora (ctest fuzz_corpus_*).
// Exit 0 when every input ran through; a crash or an unexpected exception
// fails the test and names the file.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

int main(int argc, char** argv) {
  size_t n = 0;
  for (int i = 1; i < argc; ++i) {
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(argv[i]))
      if (e.is_regular_file()) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& f : files) {
      std::ifstream in(f, std::ios::binary);
      const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      try {
        LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: unexpected exception: %s\n", f.c_str(), e.what());
        return 1;
      }
      ++n;
    }
  }
  std::printf("%zu inputs ran\n", n);
  return n > 0 ? 0 : 1;
}
