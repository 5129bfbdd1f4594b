// SPDX-License-Identifier: GPL-3.0-or-later
//
// What every `hdrstereo` command needs: the channel, global options, and
// one way to report an RPC error.
#ifndef HDRSTEREO_CLIENTS_CLI_CLIENT_H_
#define HDRSTEREO_CLIENTS_CLI_CLIENT_H_

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <iostream>
#include <memory>
#include <string>

#include "absl/time/time.h"
#include "clients/cli/connection.h"
#include "clients/cli/output.h"

namespace hdrstereo::cli {

// Exit codes, also listed in `hdrstereo --help`.
inline constexpr int kExitOk = 0;
inline constexpr int kExitError = 1;        // the server refused or failed
inline constexpr int kExitUsage = 2;        // bad command line or argument
inline constexpr int kExitUnreachable = 3;  // no daemon at --server
inline constexpr int kExitNotFound = 4;     // the named thing does not exist
inline constexpr int kExitUnauthenticated = 5;   // no or bad credentials
inline constexpr int kExitPermissionDenied = 6;  // the role does not allow it

struct GlobalOptions {
  ConnectionOptions flags;  // --server, --profile, --tls-*, --api-key-file
  Connection connection;    // resolved from them before any command runs
  bool json = false;
  double timeout_s = 10;
};

class Client {
 public:
  explicit Client(const GlobalOptions& options);

  const GlobalOptions& options() const { return options_; }
  std::shared_ptr<grpc::Channel> channel() const { return channel_; }
  // A context whose deadline is --timeout from now.
  std::unique_ptr<grpc::ClientContext> NewContext() const;
  // A context without a deadline, for streams that last as long as the work
  // (a capture being watched, a large download).
  std::unique_ptr<grpc::ClientContext> NewStreamContext() const;

  // Prints "hdrstereo: <what failed>" to stderr and returns the exit code
  // for `status`.
  int Fail(const grpc::Status& status) const;

 private:
  GlobalOptions options_;
  std::shared_ptr<grpc::Channel> channel_;
  // The deadline of the latest context: Fail() tells a call that ran out of
  // it from a device timeout the daemon reported with the same code.
  mutable absl::Time deadline_ = absl::InfiniteFuture();
};

// Finishes a command: reports a failed call, or prints `response` as JSON
// (--json) or with `print`.
template <typename Response, typename Print>
int Finish(const Client& client, const grpc::Status& rpc,
           const Response& response, Print print) {
  if (!rpc.ok()) return client.Fail(rpc);
  if (client.options().json) {
    PrintJson(std::cout, response);
  } else {
    print(response);
  }
  return kExitOk;
}

}  // namespace hdrstereo::cli

#endif  // HDRSTEREO_CLIENTS_CLI_CLIENT_H_
