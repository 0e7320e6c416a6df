#include "reefgen/files.hpp"
#include "reefgen/parallel.hpp"
#include "reefgen/sha256.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <unordered_set>
#include <vector>

namespace reefgen {

namespace {

// Temporary files being written, for a fatal signal's handler to unlink
// (SIGTERM, SIGHUP, an unhandled SIGINT): a fixed table of C strings, each
// published by its flag, so the handler only calls unlink (async-signal-safe).
// A slot is freed when its file is committed; a new file takes the next free
// slot (publish_free), so a file open for the whole run (a dataset's
// manifest) keeps its slot; only when all are taken is one reused.
constexpr size_t kLiveTemps = 256;
constexpr size_t kLiveTempPath = 4096;
struct LiveTemp {
  std::atomic<bool> ready{false};
  char path[kLiveTempPath];
};
LiveTemp g_live[kLiveTemps];
std::atomic<uint64_t> g_live_next{0};

void publish_in(LiveTemp& t, const std::string& s) {
  t.ready = false;
  std::memcpy(t.path, s.c_str(), s.size() + 1);
  t.ready = true;
}

// Publishes `path` in the next slot of a signal handler's table, in order
// (the oldest is reused when all are taken).
template <size_t N>
void publish(LiveTemp (&table)[N], std::atomic<uint64_t>& next, const fs::path& path) {
  if (path.native().size() >= kLiveTempPath) return;
  publish_in(table[next.fetch_add(1) % N], path.native());
}

// Publishes `path` in the next free slot: a file open for the whole run
// keeps its slot however many short ones come and go. Each fetch_add hands
// out its own index, so two threads never probe the same slot in one pass.
template <size_t N>
void publish_free(LiveTemp (&table)[N], std::atomic<uint64_t>& next, const fs::path& path) {
  if (path.native().size() >= kLiveTempPath) return;
  for (size_t tries = 0; tries < N; ++tries) {
    LiveTemp& t = table[next.fetch_add(1) % N];
    if (!t.ready || tries + 1 == N) return publish_in(t, path.native());
  }
}

void track_temp(const fs::path& tmp) { publish_free(g_live, g_live_next, tmp); }

void untrack_temp(const fs::path& tmp) {
  for (LiveTemp& t : g_live)
    if (t.ready && tmp.native() == t.path) t.ready = false;
}

// Folders this process created (ensure_writable_dir), outermost first, for a
// failed or killed run to remove again while they are still empty: rmdir
// removes only empty folders and is async-signal-safe.
constexpr size_t kMadeDirs = 64;
LiveTemp g_made[kMadeDirs];
std::atomic<uint64_t> g_made_next{0};

void track_made_dir(const fs::path& dir) { publish(g_made, g_made_next, dir); }

// The innermost (latest) first, so a parent made with its child goes too.
void rmdir_made_dirs() {
  const uint64_t n = g_made_next.load();
  for (uint64_t k = n; k > 0 && n - k < kMadeDirs; --k) {
    LiveTemp& t = g_made[(k - 1) % kMadeDirs];
    if (t.ready) ::rmdir(t.path);
  }
}

extern "C" void unlink_temps_and_die(int sig) {
  for (LiveTemp& t : g_live)
    if (t.ready) ::unlink(t.path);
  rmdir_made_dirs();
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

// NAME_MAX of Linux filesystems (ext4, xfs, btrfs, tmpfs), bytes.
constexpr size_t kNameMaxBytes = 255;

}  // namespace

namespace detail {

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

void (*commit_pause_for_tests)(size_t renamed) = nullptr;

fs::path write_commit_journal(const std::vector<fs::path>& temps, const std::vector<fs::path>& finals) {
  static std::atomic<uint64_t> counter{0};
  // Beside the last file of the set (a command's sidecar, staged last): the
  // folder a reader of the set looks in first.
  const fs::path dir = fs::absolute(finals.back()).parent_path();
  const fs::path journal = dir / (std::string(kCommitJournalPrefix) + std::to_string(::getpid()) + "." +
                                  std::to_string(counter.fetch_add(1)));
  std::string text = std::string(kCommitJournalHeader) + "\n";
  for (size_t i = 0; i < temps.size(); ++i)
    text += fs::absolute(temps[i]).string() + "\t" + fs::absolute(finals[i]).string() + "\n";
  write_text_atomic(journal, text);
  return journal;
}

}  // namespace detail

namespace {
// Whether `in` lies inside `folder` (through links and ../ alike).
bool lies_inside(const fs::path& in, const fs::path& folder) {
  std::error_code e1, e2;
  const fs::path a = fs::weakly_canonical(fs::absolute(in), e1), f = fs::weakly_canonical(fs::absolute(folder), e2);
  if (e1 || e2) return false;
  const fs::path rel = a.lexically_relative(f);
  return !rel.empty() && *rel.begin() != ".." && rel != ".";
}

// A journal's line is only a rename a commit of ours would make: both paths
// inside the journal's folder (its sidecar's; bundle folders below it), and
// the source a staged copy — a temporary name (NAME.tmp.PID.N) or a file a
// resumable run kept in its PREFIX.partial/. A planted journal can then not
// move a user's file over another, nor reach outside the folder.
bool a_commit_would_rename(const fs::path& tmp, const fs::path& final_path, const fs::path& dir) {
  if (!tmp.is_absolute() || !final_path.is_absolute() || tmp == final_path) return false;
  if (!lies_inside(tmp, dir) || !lies_inside(final_path, dir)) return false;
  if (tmp.filename().string().find(".tmp.") != std::string::npos) return true;
  std::error_code e1, e2;
  const fs::path rel = fs::weakly_canonical(tmp, e1).lexically_relative(fs::weakly_canonical(dir, e2));
  for (const auto& part : rel)
    if (part.extension() == ".partial") return true;
  return false;
}
}  // namespace

int finish_interrupted_commits(const fs::path& dir) {
  std::error_code ec;
  int finished = 0;
  const fs::path here = fs::absolute(dir, ec);
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    // A link named like a journal is not one of ours.
    if (name.rfind(kCommitJournalPrefix, 0) != 0 || !fs::is_regular_file(fs::symlink_status(e.path(), ec))) continue;
    const std::string rest = name.substr(std::strlen(kCommitJournalPrefix));
    const std::string pid_text = rest.substr(0, rest.find('.'));
    if (pid_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos) continue;
    const long pid = std::stol(pid_text);
    if (pid == ::getpid() || ::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;  // still committing
    std::ifstream in(e.path());
    std::string line;
    if (!std::getline(in, line) || line != kCommitJournalHeader) continue;  // not ours: left alone
    while (std::getline(in, line)) {
      const size_t tab = line.find('\t');
      if (tab == std::string::npos) continue;
      const fs::path tmp = line.substr(0, tab), final_path = line.substr(tab + 1);
      if (!a_commit_would_rename(tmp, final_path, here)) continue;
      std::error_code rc;
      // Renamed already, or gone: nothing to finish for this file.
      if (!fs::is_regular_file(fs::symlink_status(tmp, rc))) continue;
      if (final_path.has_parent_path()) fs::create_directories(final_path.parent_path(), rc);
      fs::rename(tmp, final_path, rc);
    }
    in.close();
    fs::remove(e.path(), ec);
    ++finished;
  }
  return finished;
}

void finish_interrupted_commits_around(const fs::path& file) {
  std::error_code ec;
  const fs::path dir = fs::absolute(file, ec).parent_path();
  if (ec) return;
  finish_interrupted_commits(dir);
  if (dir.has_parent_path() && dir.parent_path() != dir) finish_interrupted_commits(dir.parent_path());
}

using detail::commit_temp;
using detail::temp_path_for;

void remove_temps_on_fatal_signals() {
  for (int sig : {SIGTERM, SIGHUP, SIGINT}) ::signal(sig, unlink_temps_and_die);
}

void remove_empty_made_dirs() { rmdir_made_dirs(); }

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
    : work_(fs::absolute(work_dir).lexically_normal()), base_(fs::absolute(base).lexically_normal()) {
  // An earlier run of this set killed while committing: finished before this
  // run looks at what it kept (the journal moves kept files into place).
  finish_interrupted_commits(base_);
}

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

namespace {
// A staged file's record, written when it was settled: "SIZE SHA256".
fs::path record_of(const fs::path& kept) { return kept.string() + ".sha256"; }

std::string record_line(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) return "";
  return std::to_string(size) + " " + sha256_of_file(file.string());
}

// A file an earlier run staged, as it wrote it: a regular file (not a link
// planted there), of the size and checksum recorded when it was settled.
bool kept_intact(const fs::path& kept) {
  std::error_code ec;
  if (fs::symlink_status(kept, ec).type() != fs::file_type::regular) return false;
  if (fs::symlink_status(record_of(kept), ec).type() != fs::file_type::regular) return false;
  std::ifstream in(record_of(kept));
  std::string recorded;
  std::getline(in, recorded);
  return !recorded.empty() && recorded == record_line(kept);
}
}  // namespace

bool StagedOutputs::resumed(const fs::path& final_path) const {
  return !work_.empty() && kept_intact(kept_path(final_path));
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
  if (kept_intact(kept)) {
    ++resumed_count_;
    return {};
  }
  // Anything else there (a truncated or altered file, a link) is made again.
  fs::remove(kept, ec);
  fs::remove(record_of(kept), ec);
  fs::create_directories(kept.parent_path(), ec);
  if (ec) throw Error("cannot write " + kept.parent_path().string() + ": " + ec.message() + " (is the disk full?)");
  return temp_path_for(kept);
}

void StagedOutputs::settle(const fs::path& tmp, const fs::path& final_path) {
  if (work_.empty() || tmp.empty()) return;
  const fs::path kept = kept_path(final_path);
  commit_temp(tmp, kept);
  // The record last: a file without one is not trusted by the next run.
  write_text_atomic(record_of(kept), record_line(kept) + "\n");
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
  // The commit point: once the journal is in place the new set is decided;
  // a kill between two renames leaves the journal and the staged copies,
  // and the next sweep of the folder (remove_stale_temps) finishes the
  // renames instead of deleting them — the old set or the new one, never a
  // mix. From here a fatal signal must not unlink what the journal names.
  const fs::path journal = temps_.size() > 1 ? detail::write_commit_journal(temps_, finals_) : fs::path();
  if (!journal.empty())
    for (const fs::path& t : temps_) untrack_temp(t);
  for (size_t i = 0; i < temps_.size(); ++i) {
    if (detail::commit_pause_for_tests) detail::commit_pause_for_tests(i);
    // A resumed file's folder may not exist yet (it was made by the earlier run).
    if (!work_.empty() && finals_[i].has_parent_path()) fs::create_directories(finals_[i].parent_path(), ec);
    commit_temp(temps_[i], finals_[i]);
  }
  committed_ = true;
  if (!journal.empty()) fs::remove(journal, ec);
  if (!work_.empty()) fs::remove_all(work_, ec);
}

AtomicTextWriter::AtomicTextWriter(const fs::path& path) : path_(path), tmp_(temp_path_for(path)) {
  f_ = std::fopen(tmp_.c_str(), "wb");
  if (!f_)
    throw Error("cannot write " + path.string() + ": " + std::strerror(errno) +
                " (check that the folder exists and is writable)");
  // A streamed file (a dataset's manifest) lives for the whole run: Ctrl-C,
  // SIGTERM or SIGHUP while it is open must unlink it too.
  track_temp(tmp_);
}

AtomicTextWriter::~AtomicTextWriter() {
  if (f_) {
    std::fclose(f_);
    untrack_temp(tmp_);
    std::error_code ec;
    fs::remove(tmp_, ec);
  }
}

void AtomicTextWriter::write(const char* data, size_t n) {
  if (!f_) throw Error("cannot write " + path_.string() + ": already committed");
  if (std::fwrite(data, 1, n, f_) != n)
    throw Error("cannot write " + path_.string() + ": " + std::strerror(errno) + " (disk full?)");
}

void AtomicTextWriter::commit() {
  FILE* f = f_;
  f_ = nullptr;
  if (std::fclose(f) != 0) {
    untrack_temp(tmp_);
    std::error_code ec;
    fs::remove(tmp_, ec);
    throw Error("cannot write " + path_.string() + ": " + std::strerror(errno) + " (disk full?)");
  }
  commit_temp(tmp_, path_);
}

void write_text_atomic(const fs::path& path, const std::string& text) {
  write_file_atomic(path, text.data(), text.size());
}

namespace {

// Reads `path` in blocks, handing each to `take`, at most max_bytes in all.
template <class Take>
void read_blocks(const fs::path& path, size_t max_bytes, Take take) {
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
  std::vector<char> buf(size_t(1) << 20);
  size_t total = 0;
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error("cannot read " + path.string() + ": " + std::strerror(errno));
    if (n == 0) break;
    total += size_t(n);
    if (total > max_bytes)
      throw Error("cannot read " + path.string() + ": larger than " + std::to_string(max_bytes >> 20) +
                  " MiB, not a file reefgen reads (check the path)");
    take(buf.data(), size_t(n));
  }
  if (fifo && total == 0)
    throw Error("cannot read " + path.string() + ": a FIFO (named pipe) with nothing written to it; pass a regular file");
}

}  // namespace

std::string read_text(const fs::path& path, size_t max_bytes) {
  std::string out;
  read_blocks(path, max_bytes, [&](const char* d, size_t n) { out.append(d, n); });
  return out;
}

nlohmann::json parse_json_checked(const std::string& text, const std::string& origin) {
  using nlohmann::json;
  // The keys seen in each open object (an array's entry stays empty).
  std::vector<std::unordered_set<std::string>> open;
  const json::parser_callback_t guard = [&](int depth, json::parse_event_t event, json& parsed) {
    if (depth > kMaxJsonDepth)
      throw Error(origin + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) +
                  " levels; reefgen's files nest a few levels (see docs/SPEC.md)");
    switch (event) {
      case json::parse_event_t::object_start:
      case json::parse_event_t::array_start: open.emplace_back(); break;
      case json::parse_event_t::object_end:
      case json::parse_event_t::array_end:
        if (!open.empty()) open.pop_back();
        break;
      case json::parse_event_t::key: {
        const std::string key = parsed.get<std::string>();
        auto& seen = open.back();
        if (!seen.insert(key).second)
          throw Error(origin + ": key \"" + key + "\" appears twice in one object; keep one (the parser would silently keep the later)");
        break;
      }
      default: break;
    }
    return true;
  };
  return json::parse(text, guard);
}

nlohmann::json read_json(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error("cannot read " + path.string() + ": no such file");
  const std::string text = read_text(path, kMaxJsonBytes);
  try {
    return parse_json_checked(text, path.string());
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

void ensure_writable_dir(const fs::path& dir) {
  std::error_code ec;
  if (!dir.empty() && !fs::exists(dir, ec)) {
    // The folders missing, outermost first: a failed run removes them again.
    std::vector<fs::path> missing;
    for (fs::path p = fs::absolute(dir, ec).lexically_normal(); !p.empty() && !fs::exists(p, ec);
         p = p.parent_path()) {
      missing.insert(missing.begin(), p);
      if (p == p.parent_path()) break;
    }
    fs::create_directories(dir, ec);
    if (ec) throw Error("cannot create folder " + dir.string() + ": " + ec.message());
    for (const fs::path& p : missing) track_made_dir(p);
  }
  const fs::path d = dir.empty() ? fs::path(".") : dir;
  if (!fs::is_directory(d, ec)) throw Error(d.string() + " is not a folder");
  if (::access(d.c_str(), W_OK) != 0)
    throw Error("folder " + d.string() + " is not writable: " + std::strerror(errno));
}

namespace {

constexpr uint64_t kFnvOffset = 0xCBF29CE484222325ull, kFnvPrime = 0x100000001B3ull;  // FNV-1a 64

uint64_t fnv1a(uint64_t h, const char* data, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= kFnvPrime;
  }
  return h;
}

std::string hex64(uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)h);
  return buf;
}

}  // namespace

std::string bytes_checksum(const std::string& bytes) { return hex64(fnv1a(kFnvOffset, bytes.data(), bytes.size())); }

// Streamed: a WebDataset shard is ~1 GB. Bounded (64 GiB) like read_text,
// for a link to /dev/zero.
std::string file_checksum(const fs::path& path) {
  uint64_t h = kFnvOffset;
  read_blocks(path, size_t(64) << 30, [&](const char* d, size_t n) { h = fnv1a(h, d, n); });
  return hex64(h);
}


DirLock::DirLock(const fs::path& dir, const std::string& what, const std::string& lock_name, bool remove_when_done) {
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
  // A lock removed when done goes on a fatal signal too (SIGINT, SIGTERM,
  // SIGHUP): unlinked with the temporaries, still held, as the destructor
  // unlinks it (a world stopped with Ctrl-C left PREFIX's .world.lock).
  if (remove_when_done) remove_ = lock, track_temp(lock);
}

DirLock::~DirLock() {
  // Unlinked while still held: no other process can have taken it.
  if (!remove_.empty()) untrack_temp(remove_);
  if (fd_ >= 0 && !remove_.empty()) ::unlink(remove_.c_str());
  if (fd_ >= 0) ::close(fd_);  // releases the flock
}

int remove_stale_temps(const fs::path& dir) {
  std::error_code ec;
  int removed = 0;
  // A set whose commit was cut short is finished first (its staged copies
  // look stale); a bundle's folder sits one level below its sidecar's.
  finish_interrupted_commits(dir);
  finish_interrupted_commits(fs::absolute(dir).parent_path());
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string name = e.path().filename().string();
    const size_t at = name.rfind(".tmp.");  // NAME.tmp.PID.N
    if (at == std::string::npos) continue;
    const std::string rest = name.substr(at + 5);
    const size_t dot = rest.find('.');
    if (dot == std::string::npos || dot == 0) continue;
    const std::string p = rest.substr(0, dot), n = rest.substr(dot + 1);
    if (p.find_first_not_of("0123456789") != std::string::npos || n.empty() ||
        n.find_first_not_of("0123456789") != std::string::npos)
      continue;
    const long pid = std::stol(p);
    if (pid <= 0 || pid == ::getpid()) continue;
    if (::kill(pid_t(pid), 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    if (fs::remove(e.path(), ec)) ++removed;
  }
  return removed;
}

void refuse_output_over_input(const std::vector<fs::path>& inputs, const std::vector<fs::path>& outputs,
                              const std::vector<fs::path>& output_folders) {
  std::error_code ec;
  for (const auto& folder : output_folders)
    for (const auto& in : inputs)
      if (lies_inside(in, folder))
        throw Error(in.string() + ": this input lies in " + folder.string() +
                    ", which this run writes; copy it elsewhere or choose another output name");
  for (const auto& out : outputs)
    for (const auto& in : inputs) {
      const bool same = fs::absolute(out, ec).lexically_normal() == fs::absolute(in, ec).lexically_normal() ||
                        (fs::exists(out, ec) && fs::exists(in, ec) && fs::equivalent(out, in, ec));
      if (same)
        throw Error(out.string() + ": this output is also an input (" + in.string() +
                    "); choose another output name so the input is not overwritten");
    }
}

}  // namespace reefgen
