// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/http/rpc_routes.h"

#include <google/protobuf/message.h>
#include <google/protobuf/util/json_util.h>

#include <memory>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "processing/base/input_limits.h"

namespace hdrstereo::http {
namespace {

using google::protobuf::Message;
using google::protobuf::MethodDescriptor;

// Protobuf's parse errors name the field first ("(job_id): invalid value
// ...") or last, after some 70 bytes of text ("(page): invalid value
// Starting an object on a scalar field for type page_size"), and may echo a
// received value of any length: room for both forms, still bounded.
constexpr size_t kMaxQuotedJsonErrorBytes = 256;

std::unique_ptr<Message> NewMessage(
    const google::protobuf::Descriptor* descriptor) {
  return std::unique_ptr<Message>(
      google::protobuf::MessageFactory::generated_factory()
          ->GetPrototype(descriptor)
          ->New());
}

}  // namespace

absl::StatusOr<RpcMethod> FindRpcMethod(absl::string_view path) {
  absl::string_view rest = path;
  const std::string prefix = absl::StrCat("/", kServedPackage, ".");
  if (!absl::ConsumePrefix(&rest, prefix)) {
    return absl::NotFoundError(
        absl::StrCat("no such page: ", QuoteInput(path)));
  }
  const size_t slash = rest.find('/');
  if (slash == rest.npos || slash == 0 || slash + 1 == rest.size() ||
      rest.find('/', slash + 1) != rest.npos) {
    return absl::NotFoundError(
        absl::StrCat("no such page: ", QuoteInput(path), " (methods are at /",
                     kServedPackage, ".<Service>/<Method>)"));
  }
  const std::string service_name =
      absl::StrCat(kServedPackage, ".", rest.substr(0, slash));
  const absl::string_view method_name = rest.substr(slash + 1);
  const google::protobuf::ServiceDescriptor* service =
      google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
          service_name);
  const MethodDescriptor* method =
      service == nullptr ? nullptr
                         : service->FindMethodByName(std::string(method_name));
  if (method == nullptr) {
    return absl::UnimplementedError(
        absl::StrCat("hdrstereod serves no method ", QuoteInput(path)));
  }
  if (method->client_streaming()) {
    return absl::UnimplementedError(absl::StrCat(
        method->full_name(), " streams from the client: not served over HTTP"));
  }
  return RpcMethod{
      method, absl::StrCat("/", service->full_name(), "/", method->name())};
}

absl::StatusOr<std::string> RequestBytes(const RpcMethod& method, Codec codec,
                                         absl::string_view body) {
  const google::protobuf::Descriptor* type = method.descriptor->input_type();
  std::unique_ptr<Message> request = NewMessage(type);
  if (codec == Codec::kProto) {
    if (!request->ParseFromArray(body.data(), static_cast<int>(body.size()))) {
      return absl::InvalidArgumentError(absl::StrCat(
          "the body is not a binary ", type->full_name(), " message"));
    }
  } else {
    google::protobuf::util::JsonParseOptions options;
    options.ignore_unknown_fields = false;
    const absl::string_view json =
        absl::StripAsciiWhitespace(body).empty() ? "{}" : body;
    google::protobuf::util::Status parsed =
        google::protobuf::util::JsonStringToMessage(
            google::protobuf::StringPiece(json.data(), json.size()),
            request.get(), options);
    if (!parsed.ok()) {
      const auto message = parsed.message();
      return absl::InvalidArgumentError(absl::StrCat(
          "the body is not a JSON ", type->full_name(), ": ",
          QuoteInput(absl::string_view(message.data(), message.size()),
                     kMaxQuotedJsonErrorBytes)));
    }
  }
  return request->SerializeAsString();
}

absl::StatusOr<std::string> ResponseBody(const RpcMethod& method, Codec codec,
                                         absl::string_view bytes) {
  if (codec == Codec::kProto) return std::string(bytes);
  std::unique_ptr<Message> response =
      NewMessage(method.descriptor->output_type());
  if (!response->ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return absl::InternalError(
        absl::StrCat(method.grpc_path, " answered with bytes that are not a ",
                     method.descriptor->output_type()->full_name()));
  }
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  google::protobuf::util::Status printed =
      google::protobuf::util::MessageToJsonString(*response, &json, options);
  if (!printed.ok()) {
    return absl::InternalError(absl::StrCat("cannot write the answer of ",
                                            method.grpc_path, " as JSON"));
  }
  return json;
}

}  // namespace hdrstereo::http
