// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/rpc_bridge.h"

#include <vector>

namespace hdrstereo::http {
namespace {

grpc::ByteBuffer ToBuffer(const std::string& bytes) {
  grpc::Slice slice(bytes);
  return grpc::ByteBuffer(&slice, 1);
}

absl::Status FromGrpc(const grpc::Status& status) {
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                      status.error_message());
}

void SetDeadline(grpc::ClientContext& context, absl::Duration timeout) {
  if (timeout != absl::InfiniteDuration()) {
    context.set_deadline(absl::ToChronoTime(absl::Now() + timeout));
  }
}

}  // namespace

std::string BufferBytes(const grpc::ByteBuffer& buffer) {
  std::vector<grpc::Slice> slices;
  std::string bytes;
  if (!buffer.Dump(&slices).ok()) return bytes;
  bytes.reserve(buffer.Length());
  for (const grpc::Slice& slice : slices) {
    bytes.append(reinterpret_cast<const char*>(slice.begin()), slice.size());
  }
  return bytes;
}

void RpcBridge::Unary(const RpcMethod& method, std::string request,
                      const rpc::EdgeCaller& caller, absl::Duration timeout,
                      std::function<void(absl::StatusOr<std::string>)> done) {
  // Lives until gRPC's callback, which runs exactly once.
  struct Call {
    grpc::ClientContext context;
    grpc::ByteBuffer request;
    grpc::ByteBuffer response;
    std::function<void(absl::StatusOr<std::string>)> done;
  };
  auto* call = new Call;
  call->request = ToBuffer(request);
  call->done = std::move(done);
  stamp_.Apply(caller, call->context);
  SetDeadline(call->context, timeout);
  stub_.UnaryCall(&call->context, method.grpc_path, grpc::StubOptions(),
                  &call->request, &call->response, [call](grpc::Status status) {
                    std::unique_ptr<Call> owned(call);
                    if (status.ok()) {
                      owned->done(BufferBytes(owned->response));
                    } else {
                      owned->done(FromGrpc(status));
                    }
                  });
}

std::shared_ptr<StreamCall> RpcBridge::Stream(
    const RpcMethod& method, std::string request, const rpc::EdgeCaller& caller,
    absl::Duration timeout, std::function<void(std::string)> on_message,
    std::function<void(absl::Status)> on_done) {
  std::shared_ptr<StreamCall> call(
      new StreamCall(std::move(on_message), std::move(on_done)));
  call->self_ = call;
  call->request_ = ToBuffer(request);
  stamp_.Apply(caller, call->context_);
  SetDeadline(call->context_, timeout);
  stub_.PrepareBidiStreamingCall(&call->context_, method.grpc_path,
                                 grpc::StubOptions(), call.get());
  call->StartWriteLast(&call->request_, grpc::WriteOptions());
  // Held until the last read: OnDone cannot come while a RequestNext()
  // might still start one.
  call->AddHold();
  {
    absl::MutexLock lock(&call->mutex_);
    call->reading_ = true;
  }
  call->StartRead(&call->response_);
  call->StartCall();
  return call;
}

void StreamCall::RequestNext() {
  {
    absl::MutexLock lock(&mutex_);
    if (ended_ || reading_) return;
    reading_ = true;
  }
  StartRead(&response_);
}

void StreamCall::Cancel() {
  context_.TryCancel();
  // A read fails at once on a cancelled call and so releases the hold.
  RequestNext();
}

void StreamCall::OnReadDone(bool ok) {
  {
    // Under the lock, so that no RequestNext() starts the next read into
    // response_ before it is taken, and messages are handed on in order
    // (on_message_ only posts).
    absl::MutexLock lock(&mutex_);
    reading_ = false;
    if (ok) {
      on_message_(BufferBytes(response_));
      return;
    }
    ended_ = true;
  }
  // The stream has ended; OnDone brings its status.
  RemoveHold();
}

void StreamCall::OnDone(const grpc::Status& status) {
  // gRPC's last use of the call; whoever else holds it may still call
  // Cancel(), which is then harmless.
  std::shared_ptr<StreamCall> self = std::move(self_);
  // The callbacks hold their receiver, which may hold this call: let go,
  // on_message_ before on_done_ says the call is over.
  {
    absl::MutexLock lock(&mutex_);
    on_message_ = nullptr;
  }
  on_done_(FromGrpc(status));
  on_done_ = nullptr;
}

}  // namespace hdrstereo::http
