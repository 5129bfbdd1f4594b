// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/method_roles.h"

#include <google/protobuf/descriptor.h>

#include "absl/strings/str_cat.h"

namespace hdrstereo::rpc {
namespace {

constexpr MethodRule kRead{.min_role = Role::kViewer};
constexpr MethodRule kOperate{.min_role = Role::kOperator, .mutating = true};
constexpr MethodRule kMoveRig{
    .min_role = Role::kOperator, .mutating = true, .uses_rig = true};
// Uses the rig without changing anything recorded: live view.
constexpr MethodRule kWatchRig{.min_role = Role::kOperator, .uses_rig = true};
constexpr MethodRule kAdminister{.min_role = Role::kAdmin, .mutating = true};
constexpr MethodRule kAdminRead{.min_role = Role::kAdmin};

}  // namespace

const std::map<std::string, MethodRule, std::less<>>& MethodRules() {
  static const auto* const kRules =
      new std::map<std::string, MethodRule, std::less<>>{
          // Open to every authenticated caller, also one without a role, so
          // that a person can see why everything else is refused.
          {"/hdrstereo.v1.Server/WhoAmI", {.min_role = Role::kNone}},
          {"/hdrstereo.v1.Server/GetInfo", kRead},
          {"/grpc.health.v1.Health/Check", kRead},
          {"/grpc.health.v1.Health/Watch", kRead},
          {"/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
           kRead},

          {"/hdrstereo.v1.Hardware/GetStatus", kRead},
          {"/hdrstereo.v1.Hardware/GetCameraSettings", kRead},
          {"/hdrstereo.v1.Hardware/GetLock", kRead},
          {"/hdrstereo.v1.Hardware/SetCameraSettings", kMoveRig},
          {"/hdrstereo.v1.Hardware/HomeStage", kMoveRig},
          {"/hdrstereo.v1.Hardware/MoveStage", kMoveRig},
          {"/hdrstereo.v1.Hardware/ShowPattern", kMoveRig},
          {"/hdrstereo.v1.Hardware/BlankProjector", kMoveRig},
          // Live view is not a viewer's reading: it drives the camera (a
          // DSLR's mirror goes up, its sensor and battery run, its settings
          // compete with the stream for the hardware lane) and a person
          // holding the rig lock must be able to keep others off the camera
          // while focusing. It records nothing, so a successful stream is
          // not audited.
          {"/hdrstereo.v1.Hardware/StreamPreview", kWatchRig},
          // Shows patterns and fires the camera.
          {"/hdrstereo.v1.Hardware/ProbeProjector", kMoveRig},
          // Unlocking another principal's lock (force) needs admin: the
          // handler checks that refinement.
          {"/hdrstereo.v1.Hardware/Lock", kOperate},
          {"/hdrstereo.v1.Hardware/Unlock", kOperate},

          {"/hdrstereo.v1.Sessions/Get", kRead},
          {"/hdrstereo.v1.Sessions/List", kRead},
          {"/hdrstereo.v1.Sessions/ListFrames", kRead},
          {"/hdrstereo.v1.Sessions/ListArtifacts", kRead},
          {"/hdrstereo.v1.Sessions/DownloadArtifact", kRead},
          {"/hdrstereo.v1.Sessions/DownloadFrame", kRead},
          {"/hdrstereo.v1.Sessions/ListMetrics", kRead},
          {"/hdrstereo.v1.Sessions/Create", kOperate},
          {"/hdrstereo.v1.Sessions/Delete", kAdminister},

          {"/hdrstereo.v1.Jobs/Get", kRead},
          {"/hdrstereo.v1.Jobs/List", kRead},
          {"/hdrstereo.v1.Jobs/Watch", kRead},
          {"/hdrstereo.v1.Jobs/SubmitCapture", kMoveRig},
          // Judges a plan and reads the disk guard's numbers (a viewer sees
          // the free space in GetInfo); queues nothing, moves nothing.
          {"/hdrstereo.v1.Jobs/EstimateCapture", kRead},
          {"/hdrstereo.v1.Jobs/SubmitProcessing", kOperate},
          {"/hdrstereo.v1.Jobs/SubmitProcessingBatch", kOperate},
          {"/hdrstereo.v1.Jobs/Pause", kOperate},
          {"/hdrstereo.v1.Jobs/Resume", kOperate},
          {"/hdrstereo.v1.Jobs/Cancel", kOperate},
          // The operator at the rig has placed the calibration board.
          {"/hdrstereo.v1.Jobs/Continue", kOperate},

          {"/hdrstereo.v1.Schedules/List", kRead},
          {"/hdrstereo.v1.Schedules/ListRuns", kRead},
          // Schedules move the hardware unattended.
          {"/hdrstereo.v1.Schedules/Create", kAdminister},
          {"/hdrstereo.v1.Schedules/Delete", kAdminister},
          {"/hdrstereo.v1.Schedules/SetEnabled", kAdminister},

          {"/hdrstereo.v1.Admin/CreateApiKey", kAdminister},
          {"/hdrstereo.v1.Admin/RevokeApiKey", kAdminister},
          {"/hdrstereo.v1.Admin/ListApiKeys", kAdminRead},
          {"/hdrstereo.v1.Admin/ListAuditLog", kAdminRead},
          // Webhooks send the lab's job history to a URL of the admin's
          // choosing.
          {"/hdrstereo.v1.Admin/CreateWebhook", kAdminister},
          {"/hdrstereo.v1.Admin/DeleteWebhook", kAdminister},
          {"/hdrstereo.v1.Admin/ListWebhooks", kAdminRead},
          {"/hdrstereo.v1.Admin/ListWebhookDeliveries", kAdminRead},
      };
  return *kRules;
}

const MethodRule* FindMethodRule(absl::string_view full_method) {
  const auto& rules = MethodRules();
  auto it = rules.find(full_method);
  return it == rules.end() ? nullptr : &it->second;
}

std::vector<std::string> MethodsWithoutRule(
    const std::vector<std::string>& services) {
  std::vector<std::string> missing;
  for (const std::string& name : services) {
    const google::protobuf::ServiceDescriptor* service =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
            name);
    if (service == nullptr) {
      missing.push_back(name);
      continue;
    }
    for (int i = 0; i < service->method_count(); ++i) {
      std::string method = absl::StrCat("/", service->full_name(), "/",
                                        service->method(i)->name());
      if (FindMethodRule(method) == nullptr) missing.push_back(method);
    }
  }
  return missing;
}

}  // namespace hdrstereo::rpc
