// SPDX-License-Identifier: GPL-3.0-or-later
//
// One gRPC call of any method with an empty request, its answer's bytes
// dropped: what the tests that walk every method of the role table make,
// whatever the method's message types.
#ifndef HDRSTEREO_TESTS_SUPPORT_EMPTY_CALL_H_
#define HDRSTEREO_TESTS_SUPPORT_EMPTY_CALL_H_

#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace hdrstereo::testing {

// Calls `method` ("/hdrstereo.v1.Jobs/Cancel") on `channel` with an empty
// request within `deadline`; `prepare` adds metadata to the call.
inline grpc::Status CallWithEmptyRequest(
    const std::shared_ptr<grpc::Channel>& channel, const std::string& method,
    const std::function<void(grpc::ClientContext&)>& prepare,
    absl::Duration deadline) {
  grpc::GenericStub stub(channel);
  grpc::ClientContext context;
  context.set_deadline(absl::ToChronoTime(absl::Now() + deadline));
  prepare(context);
  grpc::Slice empty("", 0);
  grpc::ByteBuffer request(&empty, 1);
  grpc::ByteBuffer response;
  std::mutex mutex;
  std::condition_variable done_cv;
  bool done = false;
  grpc::Status status;
  stub.UnaryCall(&context, method, grpc::StubOptions(), &request, &response,
                 [&](grpc::Status s) {
                   std::lock_guard<std::mutex> lock(mutex);
                   status = std::move(s);
                   done = true;
                   done_cv.notify_all();
                 });
  std::unique_lock<std::mutex> lock(mutex);
  done_cv.wait(lock, [&] { return done; });
  return status;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_EMPTY_CALL_H_
