// SPDX-License-Identifier: GPL-3.0-or-later
#include "clients/cli/connection.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "processing/base/status_macros.h"

namespace hdrstereo::cli {
namespace {

namespace fs = std::filesystem;

absl::StatusOr<std::string> ReadFile(const fs::path& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::InvalidArgumentError(absl::StrCat(
        "cannot read ", what, " ", path.string(), ": ", std::strerror(errno)));
  }
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Secrets must be readable by their owner only.
absl::Status CheckPrivate(const fs::path& path, const char* what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "cannot read ", what, " ", path.string(), ": ", std::strerror(errno)));
  }
  if ((st.st_mode & (S_IRGRP | S_IROTH)) != 0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s %s is readable by %s (mode %04o); make it yours alone: chmod 600 "
        "%s",
        what, path.string(),
        (st.st_mode & S_IROTH) != 0 ? "other users" : "its group",
        st.st_mode & 07777, path.string()));
  }
  return absl::OkStatus();
}

fs::path ProfilePath(const std::function<const char*(const char*)>& getenv) {
  if (const char* path = getenv("HDRSTEREO_CLIENT_CONFIG"); path && *path) {
    return path;
  }
  const char* home = getenv("HOME");
  return fs::path(home != nullptr ? home : "") / ".config" / "hdrstereo" /
         "client.toml";
}

}  // namespace

absl::StatusOr<Connection> ResolveConnection(
    const ConnectionOptions& flags,
    const std::function<const char*(const char*)>& getenv) {
  auto env = [&](const char* name) -> std::string {
    const char* value = getenv(name);
    return value != nullptr ? value : "";
  };
  // The profile, when one is asked for or the file names a default.
  const fs::path file_path = ProfilePath(getenv);
  std::string wanted =
      !flags.profile.empty() ? flags.profile : env("HDRSTEREO_PROFILE");
  Profile profile;
  Connection out;
  std::error_code ec;
  if (fs::exists(file_path, ec)) {
    ASSIGN_OR_RETURN(ProfileFile file, LoadProfileFile(file_path));
    if (wanted.empty()) wanted = file.default_profile;
    if (!wanted.empty()) {
      auto it = file.profiles.find(wanted);
      if (it == file.profiles.end()) {
        std::vector<std::string> names;
        for (const auto& [name, p] : file.profiles) names.push_back(name);
        return absl::InvalidArgumentError(absl::StrCat(
            "no profile \"", wanted, "\" in ", file_path.string(),
            names.empty() ? "" : "; it has: ", absl::StrJoin(names, ", ")));
      }
      profile = it->second;
      // Paths in the file are relative to its folder.
      for (std::string* path : {&profile.tls_ca, &profile.tls_cert,
                                &profile.tls_key, &profile.api_key_file}) {
        if (!path->empty() && fs::path(*path).is_relative()) {
          *path = (file_path.parent_path() / *path).string();
        }
      }
      out.profile = wanted;
    }
  } else if (!wanted.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("profile \"", wanted, "\" asked for, but there is no ",
                     file_path.string(),
                     " (set HDRSTEREO_CLIENT_CONFIG to use another file)"));
  }
  auto pick = [&](const std::string& flag, const char* variable,
                  const std::string& from_profile) {
    if (!flag.empty()) return flag;
    if (std::string value = env(variable); !value.empty()) return value;
    return from_profile;
  };
  const std::string server =
      pick(flags.server, "HDRSTEREO_SERVER", profile.server);
  if (!server.empty()) out.server = server;
  const std::string ca = pick(flags.tls_ca, "HDRSTEREO_TLS_CA", profile.tls_ca);
  const std::string cert =
      pick(flags.tls_cert, "HDRSTEREO_TLS_CERT", profile.tls_cert);
  const std::string key =
      pick(flags.tls_key, "HDRSTEREO_TLS_KEY", profile.tls_key);
  const std::string key_file =
      pick(flags.api_key_file, "HDRSTEREO_API_KEY_FILE", profile.api_key_file);

  if (cert.empty() != key.empty()) {
    return absl::InvalidArgumentError(
        "--tls-cert and --tls-key go together (a client certificate and its "
        "private key)");
  }
  if (ca.empty()) {
    if (!cert.empty() || !key_file.empty()) {
      return absl::InvalidArgumentError(absl::StrCat(
          !cert.empty() ? "a client certificate" : "an API key",
          " is only sent over TLS: give --tls-ca (the lab CA's certificate) "
          "too, or a --profile that has tls_ca"));
    }
    return out;
  }
  out.tls = true;
  ASSIGN_OR_RETURN(out.ca_pem, ReadFile(ca, "--tls-ca"));
  if (!cert.empty()) {
    ASSIGN_OR_RETURN(out.cert_pem, ReadFile(cert, "--tls-cert"));
    RETURN_IF_ERROR(CheckPrivate(key, "--tls-key"));
    ASSIGN_OR_RETURN(out.key_pem, ReadFile(key, "--tls-key"));
  }
  if (!key_file.empty()) {
    RETURN_IF_ERROR(CheckPrivate(key_file, "--api-key-file"));
    ASSIGN_OR_RETURN(std::string text, ReadFile(key_file, "--api-key-file"));
    out.api_key = std::string(absl::StripAsciiWhitespace(text));
    if (!absl::StartsWith(out.api_key, "hs_") ||
        out.api_key.find_first_of(" \t\r\n") != std::string::npos) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--api-key-file ", key_file,
          " does not hold one API key (hs_<id>_<secret>, as `hdrstereo admin "
          "key create` printed it)"));
    }
  }
  return out;
}

std::shared_ptr<grpc::ChannelCredentials> CredentialsFor(
    const Connection& connection) {
  if (!connection.tls) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = connection.ca_pem;
  ssl.pem_cert_chain = connection.cert_pem;
  ssl.pem_private_key = connection.key_pem;
  std::shared_ptr<grpc::ChannelCredentials> credentials =
      grpc::SslCredentials(ssl);
  if (connection.api_key.empty()) return credentials;
  return grpc::CompositeChannelCredentials(
      credentials, grpc::AccessTokenCredentials(connection.api_key));
}

}  // namespace hdrstereo::cli
