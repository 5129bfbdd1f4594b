// SPDX-License-Identifier: GPL-3.0-or-later
//
// The operator's console (clients/web, built by the web_console target) as
// the HTTP edge serves it: the built files, read into memory once at
// startup from one directory (--web-root; by default
// <hdrstereod's folder>/../share/hdrstereo/web, which is both the
// installed layout bin/../share and the build tree's daemon/../share).
//
// What is loaded: the regular files directly in that directory whose names
// are plain ([A-Za-z0-9._-], not starting with '.') and whose extension is
// one the console has (.html .js .css .map .json .svg .png .ico). Anything
// else there is skipped, not refused, and listed in skipped() for the
// startup log: a subdirectory, a symbolic link (never followed), a special
// file, a hidden or oddly named file, a file of another type (a README, say).
// What is refused (Load fails, and with it the daemon's start): a file or
// the whole beyond ConsoleLimits, each checked before it is read, or a
// directory that cannot be read.
//
// Served: GET|HEAD / (index.html) and /<name> for each loaded name, with
// the sha256 as ETag (as the files route gives one) and If-None-Match; no
// credentials are needed (the files hold no secret; the API calls the page
// makes do). Nothing is served from the file system after startup, and no
// request path is ever turned into a file path: a name is looked up among
// those loaded, so /../etc/passwd or /%2e%2e/ find nothing.
#ifndef HDRSTEREO_DAEMON_HTTP_CONSOLE_FILES_H_
#define HDRSTEREO_DAEMON_HTTP_CONSOLE_FILES_H_

#include <cstddef>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::http {

struct ConsoleLimits {
  // A built console is four files of about 1 MiB together (the source map
  // is most of it).
  size_t max_file_bytes = size_t{16} << 20;
  size_t max_total_bytes = size_t{64} << 20;
  // Entries of any kind in the directory, skipped ones included.
  size_t max_entries = 256;
};

struct ConsoleFile {
  std::string name;          // "console.js"
  std::string content_type;  // "text/javascript; charset=utf-8"
  std::string etag;          // "\"<sha256, lowercase hex>\"", quoted
  std::string body;
};

// The answer to a request for a console path.
struct ConsoleAnswer {
  // 200, 304 (If-None-Match), 404 (no console is installed: `message`
  // says how to build one) or 405 (a method other than GET or HEAD).
  int status = 200;
  const ConsoleFile* file = nullptr;  // 200 and 304
  std::string message;                // 404
};

class ConsoleFiles {
 public:
  // No console: every "/" is answered with the not-installed 404.
  ConsoleFiles() = default;

  // Loads the console from `dir`. A directory that does not exist is no
  // error: the result has found() false. INVALID_ARGUMENT naming the file,
  // its size and the limit for a file or a total beyond `limits`, or for
  // too many entries; INVALID_ARGUMENT when `dir` is not a directory;
  // UNAVAILABLE naming the path for one that cannot be read.
  static absl::StatusOr<ConsoleFiles> Load(const std::filesystem::path& dir,
                                           const ConsoleLimits& limits = {});

  const std::filesystem::path& dir() const { return dir_; }
  // Whether `dir` existed at Load.
  bool found() const { return found_; }
  // Whether there is a console to serve at / (an index.html was loaded).
  bool installed() const { return files_.count("index.html") > 0; }
  size_t total_bytes() const { return total_bytes_; }
  const std::map<std::string, ConsoleFile, std::less<>>& files() const {
    return files_;
  }
  // "<name>: <why it is not served>", in name order.
  const std::vector<std::string>& skipped() const { return skipped_; }

  // Whether `path` (the request target without its query) is the console's:
  // "/" (installed or not) or "/<name>" of a loaded file.
  bool Serves(absl::string_view path) const;
  // The answer for `method` on `path`; nullopt when the path is not the
  // console's (the edge's other routes, or its 404, answer it).
  // `if_none_match`: the request's If-None-Match header ("" when absent).
  std::optional<ConsoleAnswer> Answer(absl::string_view method,
                                      absl::string_view path,
                                      absl::string_view if_none_match) const;

 private:
  const ConsoleFile* Find(absl::string_view path) const;

  std::filesystem::path dir_;
  bool found_ = false;
  std::map<std::string, ConsoleFile, std::less<>> files_;
  std::vector<std::string> skipped_;
  size_t total_bytes_ = 0;
};

// The body of the not-installed 404: what is missing and how to build it.
extern const char kConsoleNotInstalled[];

// The Content-Type the console serves a file name with (by its extension,
// case-insensitively); nullopt for a type it does not serve.
std::optional<std::string> ConsoleContentType(absl::string_view name);

// The ETag of `bytes`, as the files route gives one: the sha256 as
// lowercase hex, in double quotes.
std::string EntityTagOf(absl::string_view bytes);

// Whether an If-None-Match header value names `etag` (RFC 9110 13.1.2: a
// comma-separated list compared weakly, so W/"x" matches "x"; "*" matches
// any).
bool IfNoneMatchMatches(absl::string_view if_none_match,
                        absl::string_view etag);

// <the folder of `executable`>/../share/hdrstereo/web, normalised.
std::filesystem::path WebRootBeside(const std::filesystem::path& executable);
// WebRootBeside this process's own executable (/proc/self/exe); empty when
// it cannot be read.
std::filesystem::path DefaultWebRoot();

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_CONSOLE_FILES_H_
