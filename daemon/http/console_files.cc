// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/console_files.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <system_error>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "processing/io/sha256.h"

namespace hdrstereo::http {
namespace fs = std::filesystem;

const char kConsoleNotInstalled[] =
    "The operator's console is not installed in this hdrstereod.\n"
    "Build it with the daemon (cmake --build build builds the web_console "
    "target; it needs Node.js 20 and npm, see deploy/setup-deps.sh), install "
    "it with deploy/install.sh, or start hdrstereod with --web-root (config "
    "web-root) naming a built console. The API, /auth and /files are served "
    "as usual.\n";

namespace {

// A file descriptor closed when it goes.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }

 private:
  int fd_;
};

absl::Status ReadError(const fs::path& path, absl::string_view what,
                       int error) {
  return absl::UnavailableError(absl::StrCat(
      "cannot ", what, " ", path.string(), ": ", std::strerror(error)));
}

// Names a URL path can carry as they are, which no shell or file system
// treats specially.
bool IsPlainName(absl::string_view name) {
  return !name.empty() && name[0] != '.' &&
         std::all_of(name.begin(), name.end(), [](char c) {
           return absl::ascii_isalnum(static_cast<unsigned char>(c)) ||
                  c == '.' || c == '_' || c == '-';
         });
}

// The names in the directory `dir_fd` (without . and ..), sorted; at most
// `max_entries` of them.
absl::StatusOr<std::vector<std::string>> ListDirectory(int dir_fd,
                                                       const fs::path& dir,
                                                       size_t max_entries) {
  // fdopendir takes the descriptor over: a copy of it.
  const int copy = ::fcntl(dir_fd, F_DUPFD_CLOEXEC, 0);
  if (copy < 0) return ReadError(dir, "list", errno);
  std::unique_ptr<DIR, int (*)(DIR*)> stream(::fdopendir(copy), ::closedir);
  if (stream == nullptr) {
    const int error = errno;
    ::close(copy);
    return ReadError(dir, "list", error);
  }
  std::vector<std::string> names;
  while (true) {
    errno = 0;  // readdir's end and its error differ only by errno
    const dirent* entry = ::readdir(stream.get());
    if (entry == nullptr) {
      if (errno != 0) return ReadError(dir, "list", errno);
      break;
    }
    const absl::string_view name = entry->d_name;
    if (name == "." || name == "..") continue;
    if (names.size() == max_entries) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the console directory ", dir.string(), " holds more than ",
          max_entries,
          " entries, the limit (a built console is a handful of files)"));
    }
    names.emplace_back(name);
  }
  std::sort(names.begin(), names.end());
  return names;
}

// Reads the regular file `fd` of `size` bytes; an error when it is not
// that size by the end (it changed while being read).
absl::StatusOr<std::string> ReadExactly(int fd, size_t size,
                                        const fs::path& path) {
  std::string bytes(size, '\0');
  size_t done = 0;
  char extra = 0;
  while (true) {
    // Past the announced size: one more byte, which must not come.
    const bool past = done == size;
    const ssize_t n = past ? ::read(fd, &extra, 1)
                           : ::read(fd, bytes.data() + done, size - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return ReadError(path, "read", errno);
    }
    if (past || n == 0) {
      if (n != 0 || done != size) {
        return absl::UnavailableError(
            absl::StrCat("the console file ", path.string(),
                         " changed while it was being read"));
      }
      return bytes;
    }
    done += static_cast<size_t>(n);
  }
}

}  // namespace

absl::StatusOr<ConsoleFiles> ConsoleFiles::Load(const fs::path& dir,
                                                const ConsoleLimits& limits) {
  ConsoleFiles console;
  console.dir_ = dir;
  // The directory itself may be a symbolic link (an installer's choice);
  // nothing in it is followed.
  std::error_code error;
  const fs::file_status status = fs::status(dir, error);
  if (status.type() == fs::file_type::not_found) return console;
  if (error) {
    return absl::UnavailableError(
        absl::StrCat("cannot read the console directory ", dir.string(), ": ",
                     error.message()));
  }
  if (status.type() != fs::file_type::directory) {
    return absl::InvalidArgumentError(absl::StrCat(
        "the console directory ", dir.string(), " is not a directory"));
  }
  console.found_ = true;
  const Fd dir_fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (dir_fd.get() < 0) return ReadError(dir, "open", errno);
  absl::StatusOr<std::vector<std::string>> names =
      ListDirectory(dir_fd.get(), dir, limits.max_entries);
  if (!names.ok()) return names.status();

  for (const std::string& name : *names) {
    const fs::path path = dir / name;
    auto skip = [&](absl::string_view why) {
      console.skipped_.push_back(absl::StrCat(name, ": ", why));
    };
    struct stat entry;
    if (::fstatat(dir_fd.get(), name.c_str(), &entry, AT_SYMLINK_NOFOLLOW) !=
        0) {
      return ReadError(path, "inspect", errno);
    }
    if (S_ISLNK(entry.st_mode)) {
      skip("a symbolic link (links are not followed)");
      continue;
    }
    if (S_ISDIR(entry.st_mode)) {
      skip(
          "a directory (only files directly in the console directory are "
          "served)");
      continue;
    }
    if (!S_ISREG(entry.st_mode)) {
      skip("not a regular file");
      continue;
    }
    if (!IsPlainName(name)) {
      skip(
          "a hidden file or a name with characters other than letters, "
          "digits, '.', '_' and '-'");
      continue;
    }
    std::optional<std::string> type = ConsoleContentType(name);
    if (!type.has_value()) {
      skip(
          "not a type the console has (.html, .js, .css, .map, .json, .svg, "
          ".png, .ico)");
      continue;
    }
    // O_NOFOLLOW: a link put in its place since is not followed either;
    // O_NONBLOCK: nor does a FIFO put there block the start.
    const Fd fd(::openat(dir_fd.get(), name.c_str(),
                         O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
    if (fd.get() < 0) return ReadError(path, "open", errno);
    struct stat opened;
    if (::fstat(fd.get(), &opened) != 0) {
      return ReadError(path, "inspect", errno);
    }
    if (!S_ISREG(opened.st_mode)) {
      return absl::UnavailableError(absl::StrCat(
          "the console file ", path.string(), " changed while it was read"));
    }
    const auto size = static_cast<size_t>(opened.st_size);
    if (size > limits.max_file_bytes) {
      return absl::InvalidArgumentError(
          absl::StrCat("the console file ", path.string(), " is ", size,
                       " bytes, more than the limit of ", limits.max_file_bytes,
                       " bytes per file"));
    }
    if (size > limits.max_total_bytes - console.total_bytes_) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the console in ", dir.string(), " is more than the limit of ",
          limits.max_total_bytes, " bytes in all: ", name, " (", size,
          " bytes) comes after ", console.total_bytes_,
          " bytes of other files"));
    }
    absl::StatusOr<std::string> body = ReadExactly(fd.get(), size, path);
    if (!body.ok()) return body.status();
    console.total_bytes_ += size;
    ConsoleFile& file = console.files_[name];
    file.name = name;
    file.content_type = *std::move(type);
    file.etag = EntityTagOf(*body);
    file.body = *std::move(body);
  }
  return console;
}

const ConsoleFile* ConsoleFiles::Find(absl::string_view path) const {
  if (!absl::ConsumePrefix(&path, "/")) return nullptr;
  if (path.empty()) path = "index.html";
  const auto it = files_.find(path);
  return it == files_.end() ? nullptr : &it->second;
}

bool ConsoleFiles::Serves(absl::string_view path) const {
  return path == "/" || Find(path) != nullptr;
}

std::optional<ConsoleAnswer> ConsoleFiles::Answer(
    absl::string_view method, absl::string_view path,
    absl::string_view if_none_match) const {
  if (!Serves(path)) return std::nullopt;
  ConsoleAnswer answer;
  if (method != "GET" && method != "HEAD") {
    answer.status = 405;
    return answer;
  }
  answer.file = Find(path);
  if (answer.file == nullptr) {
    answer.status = 404;
    answer.message = kConsoleNotInstalled;
    return answer;
  }
  answer.status =
      IfNoneMatchMatches(if_none_match, answer.file->etag) ? 304 : 200;
  return answer;
}

std::optional<std::string> ConsoleContentType(absl::string_view name) {
  const size_t dot = name.rfind('.');
  if (dot == absl::string_view::npos) return std::nullopt;
  const std::string extension = absl::AsciiStrToLower(name.substr(dot + 1));
  if (extension == "html") return "text/html; charset=utf-8";
  if (extension == "js") return "text/javascript; charset=utf-8";
  if (extension == "css") return "text/css; charset=utf-8";
  if (extension == "map" || extension == "json") return "application/json";
  if (extension == "svg") return "image/svg+xml";
  if (extension == "png") return "image/png";
  if (extension == "ico") return "image/x-icon";
  return std::nullopt;
}

std::string EntityTagOf(absl::string_view bytes) {
  return absl::StrCat("\"", io::Sha256Hex(bytes), "\"");
}

bool IfNoneMatchMatches(absl::string_view if_none_match,
                        absl::string_view etag) {
  for (absl::string_view tag : absl::StrSplit(if_none_match, ',')) {
    tag = absl::StripAsciiWhitespace(tag);
    if (tag == "*") return true;
    absl::ConsumePrefix(&tag, "W/");
    if (!tag.empty() && tag == etag) return true;
  }
  return false;
}

fs::path WebRootBeside(const fs::path& executable) {
  return (executable.parent_path() / ".." / "share" / "hdrstereo" / "web")
      .lexically_normal();
}

fs::path DefaultWebRoot() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (error) return {};
  return WebRootBeside(self);
}

}  // namespace hdrstereo::http
