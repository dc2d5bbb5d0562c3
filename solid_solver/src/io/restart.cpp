// Restart checkpoints (tq/io/restart.hpp; files in docs/formats.md "Restart checkpoints").
#include "tq/io/restart.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <tuple>

#include "tq/core/types.hpp"
#include "tq/coupler/crc32.hpp"

namespace tq {

namespace {

// The last character is the state layout: raise it whenever a part changes what it saves, so that a
// checkpoint of another layout is refused by name instead of read into the wrong items.
const char kMagic[8] = {'T', 'Q', 'R', 'S', 'T', 'A', 'T', '6'};
const char* const kManifest = "checkpoint.json";

/// "" when the state file `path`, open as `is`, begins with this build's magic (`is` is left after it);
/// else why it cannot be read: another layout (named, with the fix) or not a state at all.
std::string layoutProblem(std::istream& is, const std::string& path) {
  char magic[sizeof kMagic];
  if (!is.read(magic, sizeof magic) || std::memcmp(magic, kMagic, sizeof kMagic - 1) != 0)
    return path + " is not a tq-solid checkpoint state (or it is damaged)";
  const char got = magic[sizeof kMagic - 1], want = kMagic[sizeof kMagic - 1];
  if (got != want)
    return path + " was written by another version of tq-solid (state layout " + std::string(1, got) +
           ", this build reads " + std::string(1, want) + "); run without --resume to start again";
  return "";
}

std::string sysError(const std::string& what, const std::string& path) {
  return "cannot " + what + " " + path + ": " + std::strerror(errno);
}

void fsyncPath(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) throw OutputError(sysError("open", path));
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  if (!ok) throw OutputError(sysError("sync", path));
}

/// Write all of `data` to a new file `path` and sync it.
void writeFile(const std::string& path, const std::string& data) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw OutputError(sysError("create", path));
  size_t done = 0;
  while (done < data.size()) {
    const ssize_t w = ::write(fd, data.data() + done, data.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const std::string e = sysError("write", path);
      ::close(fd);
      throw OutputError(e);
    }
    done += size_t(w);
  }
  const bool ok = ::fsync(fd) == 0;
  ::close(fd);
  if (!ok) throw OutputError(sysError("sync", path));
}

/// Copy `from` to a new file `to` and sync it; the CRC-32 of the bytes copied.
std::uint32_t copyFile(const std::string& from, const std::string& to) {
  const int in = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) throw OutputError(sysError("read", from));
  const int out = ::open(to.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out < 0) {
    ::close(in);
    throw OutputError(sysError("create", to));
  }
  std::vector<char> buf(1 << 20);
  std::string problem;
  std::uint32_t crc = 0;
  for (;;) {
    const ssize_t r = ::read(in, buf.data(), buf.size());
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      problem = sysError("read", from);
      break;
    }
    if (r == 0) break;
    crc = crc::crc32(buf.data(), size_t(r), crc);
    ssize_t done = 0;
    while (done < r) {
      const ssize_t w = ::write(out, buf.data() + done, size_t(r - done));
      if (w < 0 && errno == EINTR) continue;
      if (w <= 0) {
        problem = sysError("write", to);
        break;
      }
      done += w;
    }
    if (!problem.empty()) break;
  }
  if (problem.empty() && ::fsync(out) != 0) problem = sysError("sync", to);
  ::close(in);
  ::close(out);
  if (!problem.empty()) throw OutputError(problem);
  return crc;
}

/// The CRC-32 of a whole file (hex), or "" when it cannot be read.
std::string fileCrc(const std::string& path) {
  std::ifstream is(path, std::ios::binary);
  if (!is) return "";
  std::vector<char> buf(1 << 20);
  std::uint32_t crc = 0;
  while (is.read(buf.data(), std::streamsize(buf.size())) || is.gcount() > 0)
    crc = crc::crc32(buf.data(), size_t(is.gcount()), crc);
  return is.bad() ? "" : crc::hex(crc);
}

const char* const kManifestCrcKey = "\"manifest_crc32\"";

void renameOrThrow(const std::string& from, const std::string& to) {
  if (std::rename(from.c_str(), to.c_str()) != 0) throw OutputError(sysError("rename " + from + " to", to));
}

long long fileSize(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? (long long)st.st_size : -1;
}

/// Test hook (docs/reliability.md "Restart"): TQ_CHECKPOINT_FAULT=<sequence>:<part> kills this
/// process (SIGKILL, as a lost node) right after it wrote `part` (solid or results) of checkpoint
/// <sequence>, before the manifest.
void faultPoint(long long sequence, const char* part) {
  const char* f = std::getenv("TQ_CHECKPOINT_FAULT");
  if (!f) return;
  const std::string want = std::to_string(sequence) + ":" + part;
  if (want == f) std::raise(SIGKILL);
}

std::string seqName(const char* prefix, long long seq, const char* ext) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%s-%06lld%s", prefix, seq, ext);
  return buf;
}

/// The value of "key" in the flat JSON object `text` (a number or a string without escapes).
bool jsonValue(const std::string& text, const std::string& key, std::string& value) {
  const std::string k = "\"" + key + "\":";
  size_t p = text.find(k);
  if (p == std::string::npos) return false;
  p += k.size();
  while (p < text.size() && text[p] == ' ') ++p;
  if (p < text.size() && text[p] == '"') {
    const size_t e = text.find('"', p + 1);
    if (e == std::string::npos) return false;
    value = text.substr(p + 1, e - p - 1);
    return true;
  }
  const size_t e = text.find_first_of(",}\n", p);
  value = text.substr(p, e == std::string::npos ? std::string::npos : e - p);
  return !value.empty();
}

/// The sequence number of a checkpoint file "<prefix>-<n>.<ext>" (solid, results, checkpoint), or -1.
long long fileSequence(const std::string& n) {
  for (const char* prefix : {"solid-", "results-", "checkpoint-"}) {
    const std::string p = prefix;
    if (n.rfind(p, 0) != 0) continue;
    const size_t dot = n.find('.', p.size());
    if (dot == std::string::npos || dot == p.size()) return -1;
    const std::string digits = n.substr(p.size(), dot - p.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos) return -1;
    return std::stoll(digits);
  }
  return -1;
}

}  // namespace

std::string manifestProblem(const std::string& text) {
  const size_t k = text.rfind(kManifestCrcKey);
  if (k == std::string::npos)
    return text.size() < 2 || text.compare(text.size() - 2, 2, "}\n") != 0
               ? "it is cut short (no closing line)"
               : "it has no manifest_crc32 (written by a tq-solid without checkpoint checksums; run without --resume)";
  std::string want;
  if (!jsonValue(text.substr(k), "manifest_crc32", want) || text.compare(text.size() - 2, 2, "}\n") != 0)
    return "it is cut short";
  const std::string got = crc::hex(crc::crc32(text.data(), k));
  if (got != want) return "its CRC-32 is " + got + " instead of the " + want + " it records";
  return "";
}

std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h) {
  const auto* b = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ULL;
  return h;
}

std::string hex64(std::uint64_t h) {
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", (unsigned long long)h);
  return buf;
}

std::uint64_t runInputHash(const std::string& inputPath, const std::string& meshPath, double dt, double tEnd) {
  std::uint64_t h = fnv1a(nullptr, 0);
  for (const std::string& path : {inputPath, meshPath}) {
    std::ifstream is(path, std::ios::binary);
    std::vector<char> buf(1 << 16);
    while (is.read(buf.data(), std::streamsize(buf.size())) || is.gcount() > 0)
      h = fnv1a(buf.data(), size_t(is.gcount()), h);
  }
  const double numbers[2] = {dt, tEnd};
  return fnv1a(numbers, sizeof numbers, h);
}

std::string inputDigest(const std::string& json) {
  const std::string key = "\"digest\":";
  size_t p = json.find(key);
  if (p == std::string::npos) return "";
  p = json.find_first_not_of(' ', p + key.size());
  if (p == std::string::npos || json[p] != '"') return "";
  const size_t e = json.find('"', p + 1);
  return e == std::string::npos ? "" : json.substr(p + 1, e - p - 1);
}

RestartCheckpoints::RestartCheckpoints(std::string dir) : dir_(std::move(dir)) {
  if (::mkdir(dir_.c_str(), 0755) != 0 && errno != EEXIST) throw OutputError(sysError("create the folder", dir_));
  const std::string path = file("lock");
  lock_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_ < 0) throw OutputError(sysError("create", path));
  if (::flock(lock_, LOCK_EX | LOCK_NB) != 0) {
    char holder[32] = {0};
    const ssize_t n = ::pread(lock_, holder, sizeof holder - 1, 0);
    ::close(lock_);
    lock_ = -1;
    throw InputError("another tq-solid (pid " + std::string(n > 0 ? holder : "?") +
                     ") is running with the checkpoints in " + dir_ +
                     " (its supervisor may have been stopped); wait for it to end, or stop it, then run again");
  }
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(lock_, 0) != 0 || ::pwrite(lock_, pid.data(), pid.size(), 0) != ssize_t(pid.size()))
    throw OutputError(sysError("write", path));
}

RestartCheckpoints::~RestartCheckpoints() {
  if (lock_ >= 0) ::close(lock_);
}

void RestartCheckpoints::clear() const {
  std::remove(file(kManifest).c_str());
  DIR* d = ::opendir(dir_.c_str());
  if (!d) return;
  std::vector<std::string> names;
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    if (fileSequence(n) >= 0 || n.rfind("fluid-", 0) == 0) names.push_back(n);
  }
  ::closedir(d);
  for (const auto& n : names) std::remove(file(n).c_str());
}

bool RestartCheckpoints::last(CheckpointManifest& m, std::string& why, long long sequence) const {
  const std::string manifest = sequence > 0 ? seqName("checkpoint", sequence, ".json") : kManifest;
  std::ifstream is(file(manifest));
  if (!is) {
    why = "no checkpoint in " + dir_ + " (" + manifest + " is not there)";
    return false;
  }
  std::stringstream ss;
  ss << is.rdbuf();
  const std::string text = ss.str();
  if (const std::string p = manifestProblem(text); !p.empty()) {
    why = file(manifest) + " is damaged: " + p;
    return false;
  }
  std::string v;
  auto num = [&](const char* key, auto& out) {
    if (!jsonValue(text, key, v)) return false;
    std::istringstream vs(v);
    vs >> out;
    return bool(vs);
  };
  long long solidBytes = -1, resultsBytes = -1;
  if (!num("sequence", m.sequence) || !num("time", m.time) || !num("step", m.step) || !num("samples", m.samples) ||
      !num("solid_bytes", solidBytes) || !num("results_bytes", resultsBytes) ||
      !jsonValue(text, "fingerprint", m.fingerprint) || !jsonValue(text, "solid", m.solid) ||
      !jsonValue(text, "results", m.results) || !jsonValue(text, "solid_crc32", m.solidCrc) ||
      !jsonValue(text, "results_crc32", m.resultsCrc)) {
    why = file(manifest) + " is not a checkpoint manifest";
    return false;
  }
  if (!num("window", m.window)) m.window = -1;
  if (!jsonValue(text, "inputs", m.inputs)) m.inputs.clear();
  for (const auto& [name, bytes, crc] :
       {std::tuple{m.solid, solidBytes, m.solidCrc}, std::tuple{m.results, resultsBytes, m.resultsCrc}}) {
    const long long got = fileSize(file(name));
    if (got != bytes) {
      why = "checkpoint " + std::to_string(m.sequence) + " names " + file(name) +
            (got < 0 ? ", which is missing"
                     : ", of " + std::to_string(got) + " bytes instead of " + std::to_string(bytes));
      return false;
    }
    if (const std::string c = fileCrc(file(name)); c != crc) {
      why = "checkpoint " + std::to_string(m.sequence) + " names " + file(name) + ", whose CRC-32 is " +
            (c.empty() ? "unreadable" : c) + " instead of " + crc + " (the file is damaged)";
      return false;
    }
  }
  std::ifstream state(file(m.solid), std::ios::binary);
  why = layoutProblem(state, file(m.solid));  // before anything is written: the state's layout is this build's
  return why.empty();
}

void RestartCheckpoints::write(CheckpointManifest m, const StateArchive& a, const std::string& results) const {
  m.solid = seqName("solid", m.sequence, ".bin");
  m.results = seqName("results", m.sequence, ".h5");
  std::ostringstream os;
  os.write(kMagic, sizeof kMagic);
  a.write(os);
  const std::string state = os.str();
  writeFile(file(m.solid + ".tmp"), state);
  renameOrThrow(file(m.solid + ".tmp"), file(m.solid));
  faultPoint(m.sequence, "solid");
  const std::uint32_t resultsCrc = copyFile(results, file(m.results + ".tmp"));
  renameOrThrow(file(m.results + ".tmp"), file(m.results));
  faultPoint(m.sequence, "results");
  char t[40];
  std::snprintf(t, sizeof t, "%.17g", m.time);
  std::ostringstream js;
  js << "{\n\"format\": \"tunnelquake-checkpoint\",\n\"version\": 1,\n\"sequence\": " << m.sequence
     << ",\n\"time\": " << t << ",\n\"step\": " << m.step << ",\n\"samples\": " << m.samples << ",\n\"fingerprint\": \""
     << m.fingerprint << "\",\n\"solid\": \"" << m.solid << "\",\n\"solid_bytes\": " << state.size()
     << ",\n\"results\": \"" << m.results << "\",\n\"results_bytes\": " << fileSize(file(m.results))
     << ",\n\"solid_crc32\": \"" << crc::hex(crc::crc32(state.data(), state.size())) << "\",\n\"results_crc32\": \""
     << crc::hex(resultsCrc) << "\"";
  if (!m.inputs.empty()) js << ",\n\"inputs\": \"" << m.inputs << "\"";
  if (m.window >= 0) js << ",\n\"window\": " << m.window;
  js << ",\n";
  const std::string body = js.str();
  js << kManifestCrcKey << ": \"" << crc::hex(crc::crc32(body.data(), body.size())) << "\"\n}\n";
  if (keep_ > 1) {  // each kept checkpoint's own manifest, for a resume from the one before the last
    const std::string own = seqName("checkpoint", m.sequence, ".json");
    writeFile(file(own + ".tmp"), js.str());
    renameOrThrow(file(own + ".tmp"), file(own));
  }
  writeFile(file(std::string(kManifest) + ".tmp"), js.str());
  renameOrThrow(file(std::string(kManifest) + ".tmp"), file(kManifest));
  fsyncPath(dir_);
  // the earlier checkpoints' files (and any a stopped write left) are not named any more
  DIR* d = ::opendir(dir_.c_str());
  if (!d) return;
  std::vector<std::string> old;
  while (const dirent* e = ::readdir(d)) {
    const std::string n = e->d_name;
    const long long seq = fileSequence(n);
    if (seq >= 0 && (seq > m.sequence || seq <= m.sequence - keep_)) old.push_back(n);
  }
  ::closedir(d);
  for (const auto& n : old) std::remove(file(n).c_str());
}

void RestartCheckpoints::read(const CheckpointManifest& m, StateArchive& a) const {
  std::ifstream is(file(m.solid), std::ios::binary);
  if (const std::string why = layoutProblem(is, file(m.solid)); !why.empty()) throw InputError(why);
  if (!a.read(is)) throw InputError(file(m.solid) + " is not a tq-solid checkpoint state (or it is damaged)");
}

}  // namespace tq
