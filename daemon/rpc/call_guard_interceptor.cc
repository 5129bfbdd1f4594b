// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/call_guard_interceptor.h"

#include <google/protobuf/descriptor.h>

#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "daemon/rpc/method_roles.h"
#include "daemon/rpc/status.h"
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

std::string ResponseSubject(const Message& response) {
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

// An in-process call's connection has no transport security type: network
// ports always have one ("tls", "ssl" or "local").
bool IsInProcess(const grpc::ServerContextBase& context) {
  std::shared_ptr<const grpc::AuthContext> connection = context.auth_context();
  return connection == nullptr ||
         connection->FindPropertyValues("transport_security_type").empty();
}

class CallGuardInterceptor final : public grpc::experimental::Interceptor {
 public:
  CallGuardInterceptor(grpc::experimental::ServerRpcInfo* info,
                       CallGuard& guard, const EdgeStamp& stamp,
                       AuditLog& audit, CallDecisions& decisions)
      : context_(info->server_context()),
        method_(info->method() != nullptr ? info->method() : ""),
        rule_(FindMethodRule(method_)),
        guard_(guard),
        stamp_(stamp),
        audit_(audit),
        decisions_(decisions) {}
  ~CallGuardInterceptor() override { decisions_.Forget(context_, this); }

  void Intercept(
      grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(
            InterceptionHookPoints::POST_RECV_INITIAL_METADATA)) {
      Decide(*methods->GetRecvInitialMetadata());
    }
    if (AuditsSuccess()) {
      if (methods->QueryInterceptionHookPoint(
              InterceptionHookPoints::POST_RECV_MESSAGE)) {
        if (const void* message = methods->GetRecvMessage()) {
          request_subject_ =
              AuditSubject(*static_cast<const Message*>(message));
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
        Record(ToAbsl(methods->GetSendStatus()));
      }
    }
    methods->Proceed();
  }

 private:
  static absl::Status ToAbsl(const grpc::Status& status) {
    return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                        status.error_message());
  }

  // An admitted call the role table marks as changing something.
  bool AuditsSuccess() const {
    return decided_ && status_.ok() && rule_ != nullptr && rule_->mutating;
  }

  void Decide(std::multimap<grpc::string_ref, grpc::string_ref>& metadata) {
    decided_ = true;
    if (IsInProcess(*context_)) {
      // Only the HTTP edge's stamp names an in-process caller.
      absl::StatusOr<EdgeCaller> stamped = stamp_.Verify(metadata);
      if (stamped.ok()) {
        caller_ = {.principal = std::move(stamped->principal),
                   .transport = kHttpTransport,
                   .peer = std::move(stamped->peer)};
        status_ = guard_.Authorize(method_, caller_.principal);
      } else {
        caller_ = {.principal = {},
                   .transport = kInProcessTransport,
                   .peer = context_->peer()};
        status_ = stamped.status();
      }
    } else {
      caller_ = {.principal = {},
                 .transport = kGrpcTransport,
                 .peer = context_->peer()};
      status_ = guard_.CheckNetworkCall(method_, *context_->auth_context(),
                                        metadata, &caller_.principal);
    }
    if (status_.ok()) {
      decisions_.Record(context_, this, caller_);
    } else {
      decisions_.Record(context_, this, status_);
      // Network calls CallGuard refused never get here: this refusal is
      // the call's only audit row.
      Record(status_);
    }
  }

  void Record(const absl::Status& status) {
    std::vector<std::string> subject;
    if (!request_subject_.empty()) subject.push_back(request_subject_);
    if (!response_subject_.empty() &&
        !absl::StrContains(request_subject_, response_subject_)) {
      subject.push_back(response_subject_);
    }
    store::AuditRecord row;
    row.principal = caller_.principal.name;
    row.role = RoleName(caller_.principal.role);
    row.auth_method = caller_.principal.auth_method;
    row.transport = caller_.transport;
    row.peer = caller_.peer;
    row.method = ShownMethod(method_);
    row.subject = absl::StrJoin(subject, ", ");
    row.status_code = static_cast<int>(status.code());
    row.message = std::string(status.message());
    audit_.Record(std::move(row));
  }

  grpc::ServerContextBase* const context_;
  const std::string method_;
  const MethodRule* const rule_;  // null for a method the daemon lacks
  CallGuard& guard_;
  const EdgeStamp& stamp_;
  AuditLog& audit_;
  CallDecisions& decisions_;
  bool decided_ = false;
  absl::Status status_;
  Caller caller_;
  std::string request_subject_;
  std::string response_subject_;
};

}  // namespace

std::string AuditSubject(const Message& request) {
  std::vector<std::string> parts;
  Collect(request, parts);
  return absl::StrJoin(parts, ", ");
}

void CallDecisions::Record(const grpc::ServerContextBase* context,
                           const void* owner, absl::StatusOr<Caller> decision) {
  absl::MutexLock lock(&mutex_);
  decisions_.insert_or_assign(context, Decision{owner, std::move(decision)});
}

void CallDecisions::Forget(const grpc::ServerContextBase* context,
                           const void* owner) {
  absl::MutexLock lock(&mutex_);
  auto it = decisions_.find(context);
  if (it != decisions_.end() && it->second.owner == owner) decisions_.erase(it);
}

grpc::Status CallDecisions::Admit(const grpc::ServerContextBase& context,
                                  Caller* caller) const {
  absl::MutexLock lock(&mutex_);
  auto it = decisions_.find(&context);
  if (it == decisions_.end()) {
    return grpc::Status(grpc::StatusCode::INTERNAL,
                        "hdrstereod's guard took no decision on this call "
                        "(its interceptor is not installed); refused");
  }
  if (!it->second.caller.ok()) return ToGrpcStatus(it->second.caller.status());
  if (caller != nullptr) *caller = *it->second.caller;
  return grpc::Status::OK;
}

grpc::experimental::Interceptor*
CallGuardInterceptorFactory::CreateServerInterceptor(
    grpc::experimental::ServerRpcInfo* info) {
  return new CallGuardInterceptor(info, *guard_, stamp_, audit_, decisions_);
}

}  // namespace hdrstereo::rpc
