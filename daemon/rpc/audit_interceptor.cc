// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/audit_interceptor.h"

#include <google/protobuf/descriptor.h>

#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "daemon/rpc/method_roles.h"
#include "hdrstereo/v1/admin.pb.h"
#include "hdrstereo/v1/jobs.pb.h"

namespace hdrstereo::rpc {
namespace {

using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using grpc::experimental::InterceptionHookPoints;

// A `name` field names a session or a schedule, as its message says.
std::string EntityOf(const Message& message) {
  const std::string& type = message.GetDescriptor()->name();
  if (absl::StrContains(type, "Schedule")) return "schedule";
  if (absl::StrContains(type, "Session")) return "session";
  return "name";
}

void Collect(const Message& message, std::vector<std::string>& parts) {
  const google::protobuf::Reflection* reflection = message.GetReflection();
  std::vector<const FieldDescriptor*> fields;
  reflection->ListFields(message, &fields);
  for (const FieldDescriptor* field : fields) {
    const std::string& name = field->name();
    if (field->is_repeated()) {
      // A batch's session selectors.
      if (name == "sessions" && field->type() == FieldDescriptor::TYPE_STRING) {
        std::vector<std::string> selectors;
        for (int i = 0; i < reflection->FieldSize(message, field); ++i) {
          selectors.push_back(reflection->GetRepeatedString(message, field, i));
        }
        parts.push_back(
            absl::StrCat("sessions ", absl::StrJoin(selectors, " ")));
      }
      continue;
    }
    if (field->type() == FieldDescriptor::TYPE_MESSAGE) {
      if (name == "schedule") {
        Collect(reflection->GetMessage(message, field), parts);
      }
      continue;
    }
    if (name == "session") {
      parts.push_back(
          absl::StrCat("session ", reflection->GetString(message, field)));
    } else if (name == "name") {
      parts.push_back(absl::StrCat(EntityOf(message), " ",
                                   reflection->GetString(message, field)));
    } else if (name == "job_id") {
      parts.push_back(
          absl::StrCat("job ", reflection->GetInt64(message, field)));
    } else if (name == "id" && field->type() == FieldDescriptor::TYPE_STRING) {
      parts.push_back(
          absl::StrCat("key ", reflection->GetString(message, field)));
    } else if (name == "id" && field->type() == FieldDescriptor::TYPE_INT64 &&
               absl::StrContains(message.GetDescriptor()->name(), "Webhook")) {
      parts.push_back(
          absl::StrCat("webhook ", reflection->GetInt64(message, field)));
    } else if (name == "user") {
      parts.push_back(
          absl::StrCat("user ", reflection->GetString(message, field)));
    } else if (name == "all_sessions" && reflection->GetBool(message, field)) {
      parts.push_back("all sessions");
    } else if (name == "force" && reflection->GetBool(message, field)) {
      parts.push_back("force");
    }
  }
}

class AuditInterceptor final : public grpc::experimental::Interceptor {
 public:
  AuditInterceptor(grpc::experimental::ServerRpcInfo* info,
                   Authenticator& authenticator, AuditLog& audit)
      : info_(info), authenticator_(authenticator), audit_(audit) {}

  void Intercept(
      grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            InterceptionHookPoints::POST_RECV_MESSAGE)) {
      if (const void* message = methods->GetRecvMessage()) {
        request_subject_ = AuditSubject(*static_cast<const Message*>(message));
      }
    }
    if (methods->QueryInterceptionHookPoint(
            InterceptionHookPoints::PRE_SEND_MESSAGE)) {
      if (const void* message = methods->GetSendMessage()) {
        response_subject_ =
            ResponseSubject(*static_cast<const Message*>(message));
      }
    }
    if (methods->QueryInterceptionHookPoint(
            InterceptionHookPoints::PRE_SEND_STATUS)) {
      Record(methods->GetSendStatus());
    }
    methods->Proceed();
  }

 private:
  static std::string ResponseSubject(const Message& response) {
    if (const auto* job = dynamic_cast<const v1::Job*>(&response)) {
      return absl::StrCat("job ", job->id());
    }
    if (const auto* batch =
            dynamic_cast<const v1::SubmitProcessingBatchResponse*>(&response)) {
      std::vector<int64_t> ids;
      for (const v1::Job& job : batch->jobs()) ids.push_back(job.id());
      return absl::StrCat("jobs ", absl::StrJoin(ids, " "));
    }
    if (const auto* key =
            dynamic_cast<const v1::CreateApiKeyResponse*>(&response)) {
      return absl::StrCat("key ", key->key().id());
    }
    if (const auto* hook =
            dynamic_cast<const v1::CreateWebhookResponse*>(&response)) {
      return absl::StrCat("webhook ", hook->webhook().id());
    }
    return "";
  }

  void Record(const grpc::Status& status) {
    grpc::ServerContextBase* context = info_->server_context();
    const Principal principal =
        authenticator_.Identify(*context).value_or(Principal());
    std::vector<std::string> subject;
    if (!request_subject_.empty()) subject.push_back(request_subject_);
    if (!response_subject_.empty() &&
        !absl::StrContains(request_subject_, response_subject_)) {
      subject.push_back(response_subject_);
    }
    store::AuditRecord row;
    row.principal = principal.name;
    row.role = RoleName(principal.role);
    row.auth_method = principal.auth_method;
    row.peer = context->peer();
    row.method = info_->method();
    row.subject = absl::StrJoin(subject, ", ");
    row.status_code = static_cast<int>(status.error_code());
    row.message = status.error_message();
    audit_.Record(std::move(row));
  }

  grpc::experimental::ServerRpcInfo* info_;
  Authenticator& authenticator_;
  AuditLog& audit_;
  std::string request_subject_;
  std::string response_subject_;
};

}  // namespace

std::string AuditSubject(const Message& request) {
  std::vector<std::string> parts;
  Collect(request, parts);
  return absl::StrJoin(parts, ", ");
}

grpc::experimental::Interceptor*
AuditInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  const MethodRule* rule = FindMethodRule(info->method());
  if (rule == nullptr || !rule->mutating) return nullptr;
  return new AuditInterceptor(info, authenticator_, audit_);
}

}  // namespace hdrstereo::rpc
