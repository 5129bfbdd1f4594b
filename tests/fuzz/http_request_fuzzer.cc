// SPDX-License-Identifier: GPL-3.0-or-later
// What an HTTP client sends the daemon's HTTP edge, past Boost.Beast's own
// parsing: the headers the edge reads (Content-Type, Connect-Timeout-Ms,
// Host, Origin, Cookie, Range), the route and the body. The input is those
// six header values and the path, one a line, then the body (which may hold
// newlines).
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/stubs/logging.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "daemon/http/connect_protocol.h"
#include "daemon/http/request_checks.h"
#include "daemon/http/rpc_routes.h"
#include "hdrstereo/v1/admin.pb.h"
#include "hdrstereo/v1/common.pb.h"
#include "hdrstereo/v1/hardware.pb.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "hdrstereo/v1/schedules.pb.h"
#include "hdrstereo/v1/server.pb.h"
#include "hdrstereo/v1/sessions.pb.h"
#include "nlohmann/json.hpp"
#include "tests/fuzz/fuzz_support.h"

namespace {

namespace http = hdrstereo::http;
namespace v1 = hdrstereo::v1;

// The body limit of the edge's default options (http_edge.h).
constexpr size_t kMaxBodyBytes = size_t{4} << 20;

// Every method of the served package, from the generated pool (one message
// of each .proto file keeps its descriptors linked), so that a body meets a
// method also when the path names none.
const std::vector<http::RpcMethod>& AllMethods() {
  static const std::vector<http::RpcMethod> methods = [] {
    // Protobuf logs each string that is not UTF-8; a fuzzer makes many.
    google::protobuf::SetLogHandler(nullptr);
    std::vector<http::RpcMethod> all;
    for (const google::protobuf::Descriptor* linked :
         {v1::PageRequest::descriptor(), v1::ServerInfo::descriptor(),
          v1::HardwareStatus::descriptor(), v1::Session::descriptor(),
          v1::Job::descriptor(), v1::Schedule::descriptor(),
          v1::ApiKey::descriptor()}) {
      const google::protobuf::FileDescriptor* file = linked->file();
      for (int s = 0; s < file->service_count(); ++s) {
        const google::protobuf::ServiceDescriptor* service = file->service(s);
        for (int m = 0; m < service->method_count(); ++m) {
          absl::StatusOr<http::RpcMethod> method =
              http::FindRpcMethod(absl::StrCat("/", service->full_name(), "/",
                                               service->method(m)->name()));
          FUZZ_CHECK(method.ok() && method->descriptor == service->method(m));
          all.push_back(*method);
        }
      }
    }
    FUZZ_CHECK(!all.empty());
    return all;
  }();
  return methods;
}

// `bytes` parse as a `type` message.
bool ParsesAs(const google::protobuf::Descriptor* type,
              const std::string& bytes) {
  std::unique_ptr<google::protobuf::Message> message(
      google::protobuf::MessageFactory::generated_factory()
          ->GetPrototype(type)
          ->New());
  return message->ParseFromString(bytes);
}

void CheckContentType(absl::string_view header) {
  const std::optional<http::ContentType> type = http::ParseContentType(header);
  if (!type.has_value()) return;
  // What the edge answers with reads back as the same type.
  const std::optional<http::ContentType> named =
      http::ParseContentType(http::ContentTypeName(*type));
  FUZZ_CHECK(named.has_value() && named->codec == type->codec &&
             named->streaming == type->streaming);
}

void CheckTimeout(absl::string_view header) {
  absl::StatusOr<absl::Duration> timeout = http::ParseTimeoutMs(header);
  if (!timeout.ok()) return;
  FUZZ_CHECK(*timeout >= absl::Milliseconds(1) &&
             *timeout <= absl::Milliseconds(9'999'999'999));
}

void CheckHostAndOrigin(absl::string_view host, absl::string_view origin) {
  absl::StatusOr<std::string> name = http::HostName(host);
  if (name.ok()) {
    FUZZ_CHECK(!name->empty() && name->size() <= host.size());
    FUZZ_CHECK(absl::AsciiStrToLower(*name) == *name);
    // A host serves its own name.
    FUZZ_CHECK(http::CheckHost(host, {*name}).ok());
  } else {
    FUZZ_CHECK(!http::CheckHost(host, {"lab-pc"}).ok());
  }
  (void)http::CheckHost(host, {"lab-pc", "127.0.0.1", "[::1]"});
  (void)http::CheckOrigin(origin, "https", host);
}

void CheckCookie(absl::string_view header) {
  const std::optional<std::string> value =
      http::CookieValue(header, "hdrstereo_session");
  if (!value.has_value()) return;
  // The value is a piece of the header.
  FUZZ_CHECK(header.find(*value) != absl::string_view::npos);
}

void CheckRange(absl::string_view header) {
  const std::optional<http::ByteRange> range = http::ParseRange(header);
  if (!range.has_value()) return;
  FUZZ_CHECK(range->first >= 0);
  FUZZ_CHECK(!range->last.has_value() || *range->last >= range->first);
  for (int64_t total : {int64_t{0}, int64_t{1}, int64_t{4096}, range->first,
                        range->first + 1, int64_t{999'999'999'999'999'999}}) {
    absl::StatusOr<http::ResolvedRange> resolved =
        http::ResolveRange(*range, total);
    if (!resolved.ok()) {
      FUZZ_CHECK(range->first >= total);
      continue;
    }
    // Within the file, at least one byte, starting where asked.
    FUZZ_CHECK(resolved->offset == range->first);
    FUZZ_CHECK(resolved->length >= 1);
    FUZZ_CHECK(resolved->length <= total - resolved->offset);
  }
}

void CheckEnvelope(absl::string_view body) {
  absl::StatusOr<absl::string_view> payload =
      http::ParseRequestEnvelope(body, kMaxBodyBytes);
  if (payload.ok()) {
    // Inside the body, right after the prefix.
    FUZZ_CHECK(payload->data() == body.data() + http::kEnvelopeHeaderBytes);
    FUZZ_CHECK(payload->size() == body.size() - http::kEnvelopeHeaderBytes);
  }
  const std::string enveloped = http::Envelope(0, body);
  absl::StatusOr<absl::string_view> back =
      http::ParseRequestEnvelope(enveloped, body.size());
  FUZZ_CHECK(back.ok() && *back == body);
}

void CheckErrorBodies(absl::string_view text) {
  // Whatever a gRPC message quotes, the error bodies are JSON.
  const absl::Status status(absl::StatusCode::kInvalidArgument, text);
  FUZZ_CHECK(nlohmann::json::accept(http::ErrorJson(status)));
  FUZZ_CHECK(nlohmann::json::accept(http::EndStreamJson(status)));
}

void CheckBody(const http::RpcMethod& method, absl::string_view body) {
  const google::protobuf::MethodDescriptor& descriptor = *method.descriptor;
  for (http::Codec codec : {http::Codec::kJson, http::Codec::kProto}) {
    absl::StatusOr<std::string> request =
        http::RequestBytes(method, codec, body);
    if (!request.ok()) continue;
    // What is forwarded is a request the gRPC side can read.
    FUZZ_CHECK(ParsesAs(descriptor.input_type(), *request));
    // Answers come back through the same conversion; bytes the method did
    // not answer with are an error, not a crash.
    for (http::Codec answer : {http::Codec::kJson, http::Codec::kProto}) {
      absl::StatusOr<std::string> response =
          http::ResponseBody(method, answer, *request);
      if (response.ok() && answer == http::Codec::kJson) {
        FUZZ_CHECK(nlohmann::json::accept(*response));
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<http::RpcMethod>& methods = AllMethods();
  const absl::string_view text = hdrstereo::fuzz::AsText(data, size);
  std::vector<absl::string_view> fields =
      absl::StrSplit(text, absl::MaxSplits('\n', 7));
  fields.resize(8);
  const absl::string_view body = fields[7];
  CheckContentType(fields[0]);
  CheckTimeout(fields[1]);
  CheckHostAndOrigin(fields[2], fields[3]);
  CheckCookie(fields[4]);
  CheckRange(fields[5]);
  CheckEnvelope(body);
  CheckErrorBodies(text);

  absl::StatusOr<http::RpcMethod> method = http::FindRpcMethod(fields[6]);
  if (method.ok()) {
    FUZZ_CHECK(method->grpc_path == fields[6]);
    FUZZ_CHECK(!method->descriptor->client_streaming());
  }
  // A path that names no method still sends its body to one.
  CheckBody(method.ok() ? *method : methods[fields[6].size() % methods.size()],
            body);
  return 0;
}
