#pragma once
// Files with the project's conventions: every write goes to a temporary
// file in the destination folder and is renamed into place, so a crash, a
// full disk or a kill never leaves a half-written file under the final name;
// folder locks, stale temporaries, outputs that would overwrite inputs.
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "reefgen/error.hpp"

namespace reefgen {

namespace fs = std::filesystem;

// Writes bytes atomically (temp file + fsync-free rename). Throws Error naming
// the path on failure and removes the temporary file.
void write_file_atomic(const fs::path& path, const void* data, size_t size);
void write_text_atomic(const fs::path& path, const std::string& text);
// Reads a whole file, at most max_bytes (a device such as /dev/zero or a huge
// file by mistake gets an error, not all the memory); folders are refused.
std::string read_text(const fs::path& path, size_t max_bytes = size_t(1) << 30);
// Configs, specs and sidecars: at most kMaxJsonBytes; errors name the file
// (missing, a folder, too large, the byte of a syntax error).
constexpr size_t kMaxJsonBytes = size_t(16) << 20;
nlohmann::json read_json(const fs::path& path);
// Nesting deeper than this is refused before it is built (a spec of 100,000
// nested arrays overflowed the stack): no config, spec or sidecar of
// reefgen's nests past a dozen levels.
constexpr int kMaxJsonDepth = 256;
// JSON text parsed with two guards nlohmann's parser lacks: nesting deeper
// than kMaxJsonDepth and a key repeated within one object (the parser keeps
// the later value without a word) throw reefgen::Error naming `origin`
// (a file name, "request body", ...) and the fix. Syntax errors propagate
// as nlohmann::json::parse_error (read_json names their byte).
nlohmann::json parse_json_checked(const std::string& text, const std::string& origin);
void write_json_atomic(const fs::path& path, const nlohmann::json& j);

// A text file written as a stream (memory stays flat however long it gets)
// to a temporary name, renamed into place by commit(); dropped without
// commit() (an exception, an interrupted build), it leaves nothing behind.
class AtomicTextWriter {
 public:
  explicit AtomicTextWriter(const fs::path& path);
  ~AtomicTextWriter();
  AtomicTextWriter(const AtomicTextWriter&) = delete;
  AtomicTextWriter& operator=(const AtomicTextWriter&) = delete;
  void write(const std::string& text) { write(text.data(), text.size()); }
  void write(const char* data, size_t n);  // bytes too: the file is opened in binary mode
  void commit();

 private:
  fs::path path_, tmp_;
  FILE* f_ = nullptr;
};

// The outputs of one run, all or nothing. Each file is written under a
// temporary name beside its final one (NAME.tmp.PID.N, which
// remove_stale_temps recognises) and commit() renames them all into place
// once everything has been written. A run that fails before commit() — bad
// input, full disk, an output path that is a folder — leaves every file that
// existed before it exactly as it was, and nothing new: the destructor removes
// what was staged. The first write into a folder also removes the temporaries
// that killed runs left there (remove_stale_temps), so a kill -9 leaves
// nothing behind once the command is run again.
class StagedOutputs {
 public:
  StagedOutputs() = default;
  // Resumable (a long run, e.g. a world's tiles): each file is staged as
  // work_dir / (its final path relative to `base`), renamed there as soon as
  // it is written, and kept when the run stops before commit(): a later run
  // with the same work_dir does not write it again (resumed() says so before
  // the work that would make it) and commit() moves it into place, then
  // removes work_dir. The caller keys work_dir to what the run makes.
  StagedOutputs(fs::path work_dir, fs::path base);
  ~StagedOutputs();
  StagedOutputs(const StagedOutputs&) = delete;
  StagedOutputs& operator=(const StagedOutputs&) = delete;
  // Runs writer(temp path) for the final path; errors name the final path.
  // Throws Error when the final path is a folder or already staged in this run.
  void write(const fs::path& final_path, const std::function<void(const fs::path&)>& writer);
  // The same for several files, their writers run on `threads` threads (the
  // files are independent: same bytes whatever the count). On failure the
  // error of the first failing file in list order is thrown.
  using Job = std::pair<fs::path, std::function<void(const fs::path&)>>;
  void write_all(const std::vector<Job>& jobs, int threads);
  // Renames every staged file into place, in staging order (stage sidecars
  // last). Checks first that no destination has become a folder.
  void commit();
  const std::vector<fs::path>& finals() const { return finals_; }
  // True when an earlier, interrupted run left `final_path` staged in work_dir.
  bool resumed(const fs::path& final_path) const;
  // Files this run found staged already (resumable only).
  size_t resumed_count() const { return resumed_count_; }

 private:
  // Checks and registers final_path; returns where its writer writes, or an
  // empty path when it is resumed (nothing to write).
  fs::path stage(const fs::path& final_path);
  // After the writer: a resumable run renames the temporary into work_dir.
  void settle(const fs::path& tmp, const fs::path& final_path);
  fs::path kept_path(const fs::path& final_path) const;

  fs::path work_, base_;
  size_t resumed_count_ = 0;
  std::vector<fs::path> temps_, finals_;
  std::vector<fs::path> swept_dirs_;  // folders already cleared of stale temporaries
  bool committed_ = false;
};

// Throws Error unless `dir` exists (or can be created) and is writable.
void ensure_writable_dir(const fs::path& dir);

// An exclusive lock on a folder (a run folder, a dataset being built), held
// for the object's lifetime through DIR/.reefgen.lock (flock: released by the
// kernel when the process dies, so a kill -9 never leaves a stale lock).
// Throws Error naming the folder and the other process when it is taken.
// With remove_when_done the lock file is unlinked when the lock is released
// (a lock beside a user's own files, not left behind by a run that ends;
// a killed run leaves an empty file that the next run reuses).
class DirLock {
 public:
  DirLock(const fs::path& dir, const std::string& what, const std::string& lock_name = ".reefgen.lock",
          bool remove_when_done = false);
  ~DirLock();
  DirLock(const DirLock&) = delete;
  DirLock& operator=(const DirLock&) = delete;

 private:
  int fd_ = -1;
  fs::path remove_;
};

// Removes temporary files left by killed processes in `dir` (not recursive):
// NAME.tmp.PID.N (every temporary name of the project, temp_path_for) whose
// PID is not a live process. Returns how many were removed. Commits
// cut short in `dir` or its parent are finished first.
int remove_stale_temps(const fs::path& dir);
// StagedOutputs::commit() of more than one file first writes a journal,
// DIR/.reefgen.commit.PID.N beside the set's last file, naming each staged
// copy and its final path, and removes it after the last rename. For every
// journal in `dir` whose process is gone, the renames it names are finished
// (staged copies still there are moved into place) and the journal removed:
// a kill during a commit leaves the new set, never a mix of two runs.
// Returns how many journals were finished.
int finish_interrupted_commits(const fs::path& dir);
// Before a command reads files another run wrote (realism, erode): a commit
// cut short in the file's folder or the one above it (a bundle's file sits
// one below its sidecar) is finished first, so the reader sees one run's
// set, never a mix. Finishing needs the folder writable; where it is not,
// the files are read as they are.
void finish_interrupted_commits_around(const fs::path& file);
constexpr const char* kCommitJournalPrefix = ".reefgen.commit.";
constexpr const char* kCommitJournalHeader = "reefgen-commit-journal 1";
namespace detail {
// Tests only: called before the i-th rename of a commit (a child process
// _exits there to stand for a kill in the middle of the renames).
extern void (*commit_pause_for_tests)(size_t renamed);
fs::path write_commit_journal(const std::vector<fs::path>& temps, const std::vector<fs::path>& finals);
}  // namespace detail
// SIGTERM, SIGHUP and SIGINT unlink the temporary files this process is
// writing, then end it as the signal would: a killed `infer` leaves no
// *.tmp.* behind. Commands with their own graceful stop (train, studio)
// install theirs afterwards for the signals they handle.
void remove_temps_on_fatal_signals();
// Removes the folders ensure_writable_dir created in this process that are
// still empty (innermost first): a run that failed leaves no empty bundle
// folder behind. The fatal-signal handler does the same.
void remove_empty_made_dirs();

// Throws Error when an output path is one of the inputs (same file by inode,
// or the same path): a run must never overwrite what it reads.
// Folders the run writes into (engine bundles, PREFIX.<engine>/) count too:
// an input inside one of them is refused.
void refuse_output_over_input(const std::vector<fs::path>& inputs, const std::vector<fs::path>& outputs,
                              const std::vector<fs::path>& output_folders = {});

// A stable checksum for manifests: FNV-1a 64 of the file's bytes, as hex.
std::string file_checksum(const fs::path& path);
// The same checksum of bytes in memory (a tar member, a file about to be written).
std::string bytes_checksum(const std::string& bytes);

// `-o PREFIX` writes PREFIX.height.exr and its siblings PREFIX.json, ...;
// `-o NAME.exr` (or NAME.height.exr) writes exactly that height file and its
// siblings under NAME (NAME.json, NAME.label.png, ...).
struct OutputNames {
  fs::path prefix, height;
};
inline OutputNames output_names(const std::string& o) {
  fs::path p(o);
  // "-o out/" would write hidden files out/.height.exr, out/.json, ...
  if (p.filename().empty() || p.filename() == "." || p.filename() == "..")
    throw Error("-o " + o + ": a folder, not a file prefix; give a name in it, e.g. -o " +
                (p.filename().empty() ? o : o + "/") + "island");
  if (p.extension() == ".exr") {
    fs::path stem = p;
    stem.replace_extension();
    if (stem.extension() == ".height") stem.replace_extension();
    return {stem, p};
  }
  return {p, fs::path(o + ".height.exr")};
}

namespace detail {
// For a library that writes a path itself (OpenEXR): a temporary name beside
// `path`, removed by a fatal signal (remove_temps_on_fatal_signals), and its
// rename into place (Error naming `path` on failure).
fs::path temp_path_for(const fs::path& path);
void commit_temp(const fs::path& tmp, const fs::path& path);
}  // namespace detail

}  // namespace reefgen
