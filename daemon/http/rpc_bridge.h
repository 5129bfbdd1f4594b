// SPDX-License-Identifier: GPL-3.0-or-later
//
// The HTTP edge's calls into the services: through the server's in-process
// channel with the caller stamped (rpc::EdgeStamp), so that the guard
// every path runs decides.
#ifndef HDRSTEREO_DAEMON_HTTP_RPC_BRIDGE_H_
#define HDRSTEREO_DAEMON_HTTP_RPC_BRIDGE_H_

#include <google/protobuf/descriptor.h>
#include <grpcpp/channel.h>
#include <grpcpp/client_context.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/support/client_callback.h>

#include <functional>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "absl/time/time.h"
#include "daemon/http/connect_protocol.h"
#include "daemon/http/rpc_routes.h"
#include "daemon/rpc/edge_stamp.h"

namespace hdrstereo::http {

// A server-streaming call in flight. Messages arrive one at a time: after
// `on_message`, the next is read only when RequestNext() is called, so a
// slow reader holds back the service (gRPC flow control), never a buffer.
class StreamCall;

class RpcBridge {
 public:
  RpcBridge(std::shared_ptr<grpc::Channel> channel, const rpc::EdgeStamp& stamp)
      : stub_(std::move(channel)), stamp_(stamp) {}

  // A unary call; `done` runs once, on a gRPC thread, with the response
  // message's bytes or the call's status (the gRPC message unchanged).
  void Unary(const RpcMethod& method, std::string request,
             const rpc::EdgeCaller& caller, absl::Duration timeout,
             std::function<void(absl::StatusOr<std::string>)> done);

  // Starts a server-streaming call; `on_message` runs for each message,
  // `on_done` once at the end, both on gRPC threads (never at once).
  std::shared_ptr<StreamCall> Stream(
      const RpcMethod& method, std::string request,
      const rpc::EdgeCaller& caller, absl::Duration timeout,
      std::function<void(std::string)> on_message,
      std::function<void(absl::Status)> on_done);

 private:
  grpc::GenericStub stub_;
  const rpc::EdgeStamp& stamp_;
};

class StreamCall
    : public grpc::ClientBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  // Reads the next message (once per message received; nothing after the
  // stream ended).
  void RequestNext();
  // Ends the call (the client went away); on_done follows.
  void Cancel();

  void OnReadDone(bool ok) override;
  void OnDone(const grpc::Status& status) override;

 private:
  friend class RpcBridge;
  StreamCall(std::function<void(std::string)> on_message,
             std::function<void(absl::Status)> on_done)
      : on_message_(std::move(on_message)), on_done_(std::move(on_done)) {}

  grpc::ClientContext context_;
  absl::Mutex mutex_;
  bool reading_ ABSL_GUARDED_BY(mutex_) = false;
  bool ended_ ABSL_GUARDED_BY(mutex_) = false;
  grpc::ByteBuffer request_;
  grpc::ByteBuffer response_;
  std::function<void(std::string)> on_message_ ABSL_GUARDED_BY(mutex_);
  std::function<void(absl::Status)> on_done_;
  // Keeps the call alive until gRPC is done with it.
  std::shared_ptr<StreamCall> self_;
};

// A ByteBuffer's bytes.
std::string BufferBytes(const grpc::ByteBuffer& buffer);

}  // namespace hdrstereo::http

#endif  // HDRSTEREO_DAEMON_HTTP_RPC_BRIDGE_H_
