// read_file and not_a_regular_file (limits.h): the one reader of outside files.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "se3_sim/model/limits.h"

namespace se3 {
namespace {

// What a stat mode is, when it is not a regular file ("" when it is).
std::string kind_of(mode_t mode) {
  if (S_ISREG(mode)) return "";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string errno_text(int e) {
  if (e == ENOENT || e == ENOTDIR) return "not found";
  return std::string("unreadable (") + std::strerror(e) + ")";
}

// Opens a regular file for reading without blocking on whatever the path is; -1 and *why.
int open_regular(const std::string& path, struct stat& st, std::string* why) {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return -1;
  };
  if (path.empty()) return fail("not found (an empty path)");
  if (::stat(path.c_str(), &st) != 0) return fail(errno_text(errno));
  std::string kind = kind_of(st.st_mode);
  if (!kind.empty()) return fail(kind);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) return fail(errno_text(errno));
  if (::fstat(fd, &st) != 0 || !(kind = kind_of(st.st_mode)).empty()) {
    ::close(fd);
    return fail(kind.empty() ? std::string("unreadable") : kind);
  }
  return fd;
}

}  // namespace

std::string not_a_regular_file(const std::string& path) {
  struct stat st;
  std::string why;
  const int fd = open_regular(path, st, &why);
  if (fd >= 0) ::close(fd);
  return why;
}

bool read_file(const std::string& path, std::string& out, std::string* why, std::size_t max_bytes,
               bool prefix) {
  out.clear();
  struct stat st;
  const int fd = open_regular(path, st, why);
  if (fd < 0) return false;
  auto too_big = [&](std::uint64_t size) {
    ::close(fd);
    out.clear();
    if (why) *why = std::to_string(size) + " bytes, more than the " + std::to_string(max_bytes);
    return false;
  };
  if (!prefix && static_cast<std::uint64_t>(st.st_size) > max_bytes) return too_big(st.st_size);
  // A regular file never blocks a read; the size may change while it is read, so the bound is
  // kept on what is read, not on what stat said.
  out.reserve(std::min<std::size_t>(max_bytes, static_cast<std::size_t>(st.st_size)));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int e = errno;
      ::close(fd);
      out.clear();
      if (why) *why = std::string("unreadable (") + std::strerror(e) + ")";
      return false;
    }
    if (n == 0) break;
    out.append(buf, static_cast<std::size_t>(n));
    if (out.size() > max_bytes) {
      if (!prefix) return too_big(out.size());
      out.resize(max_bytes);
      break;
    }
  }
  ::close(fd);
  return true;
}

std::string package_root(std::string dir) {
  for (int depth = 0; depth < 32 && !dir.empty(); ++depth) {
    if (not_a_regular_file(dir + "/package.xml").empty()) return dir;
    const auto slash = dir.find_last_of('/');
    if (dir == "/" || slash == std::string::npos) break;
    dir = slash == 0 ? "/" : dir.substr(0, slash);
  }
  return "";
}

std::string dt_problem(double dt) {
  if (!std::isfinite(dt)) return "is not a finite number";
  if (!(dt > 0)) return "is not positive";
  if (dt < limits::kMinDt) return "is below the smallest step, 1e-9 s (docs/robustness.md)";
  return "";
}

std::string three_figures(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", x);
  return buf;
}

}  // namespace se3
