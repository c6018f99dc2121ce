// SPDX-License-Identifier: Apache-2.0
#include "atomic_write.h"

#include <cerrno>
#include <cstring>
#include <string>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "vfit/kernels/error.h"

namespace vfit {

void write_file_atomically(const std::filesystem::path& path, std::string_view bytes) {
  const std::filesystem::path dir = path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
  std::string tmpl = (dir / ("." + path.filename().string() + ".vfit-tmp-XXXXXX")).string();
  int fd = mkstemp(tmpl.data());
  if (fd < 0) throw Error(path.string(), 0, std::string("cannot create output: ") + std::strerror(errno));
  auto fail = [&](const char* what) {
    const int e = errno;
    close(fd);
    unlink(tmpl.c_str());
    throw Error(path.string(), 0, std::string(what) + ": " + std::strerror(e));
  };
  const char* p = bytes.data();
  std::size_t left = bytes.size();
  while (left > 0) {
    ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write output");
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  // mkstemp creates 0600; give the file the usual permissions under the process umask.
  mode_t mask = umask(0);
  umask(mask);
  if (fchmod(fd, 0666 & ~mask) != 0) fail("cannot set permissions of output");
  if (fsync(fd) != 0) fail("cannot flush output");
  if (close(fd) != 0) {
    const int e = errno;
    unlink(tmpl.c_str());
    throw Error(path.string(), 0, std::string("cannot close output: ") + std::strerror(e));
  }
  if (std::rename(tmpl.c_str(), path.c_str()) != 0) {
    const int e = errno;
    unlink(tmpl.c_str());
    throw Error(path.string(), 0, std::string("cannot rename output into place: ") + std::strerror(e));
  }
}

std::string read_file_bytes(const std::filesystem::path& path) {
  int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path.string(), 0, std::string("cannot open: ") + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    close(fd);
    throw Error(path.string(), 0, "cannot read: not a regular file");
  }
  std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < bytes.size()) {
    ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = errno;
      close(fd);
      throw Error(path.string(), 0,
                  std::string("cannot read: ") + (n == 0 ? "file shrank while reading" : std::strerror(e)));
    }
    got += static_cast<std::size_t>(n);
  }
  close(fd);
  return bytes;
}

} // namespace vfit
