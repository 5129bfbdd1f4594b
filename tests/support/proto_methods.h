// SPDX-License-Identifier: GPL-3.0-or-later
//
// Every method of every service in proto/hdrstereo/v1, read from the
// generated descriptor pool for each .proto file in the source tree: what
// tests walk to prove that no method escapes the role table. Link
// hdrstereo_proto.
#ifndef HDRSTEREO_TESTS_SUPPORT_PROTO_METHODS_H_
#define HDRSTEREO_TESTS_SUPPORT_PROTO_METHODS_H_

#include <google/protobuf/descriptor.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "hdrstereo/v1/admin.pb.h"
#include "hdrstereo/v1/common.pb.h"
#include "hdrstereo/v1/hardware.pb.h"
#include "hdrstereo/v1/jobs.pb.h"
#include "hdrstereo/v1/schedules.pb.h"
#include "hdrstereo/v1/server.pb.h"
#include "hdrstereo/v1/sessions.pb.h"

namespace hdrstereo::testing {

struct ProtoMethod {
  std::string full_name;  // "/hdrstereo.v1.Jobs/Cancel"
  const google::protobuf::MethodDescriptor* descriptor;
};

// Fails the test for a .proto file whose descriptors are not linked in.
inline std::vector<ProtoMethod> AllProtoMethods() {
  // One message of each file, so that the linker keeps its descriptors.
  const google::protobuf::Descriptor* linked[] = {
      v1::PageRequest::descriptor(),
      v1::ServerInfo::descriptor(),
      v1::HardwareStatus::descriptor(),
      v1::Session::descriptor(),
      v1::Job::descriptor(),
      v1::Schedule::descriptor(),
      v1::ApiKey::descriptor()};
  (void)linked;
  std::vector<ProtoMethod> methods;
  const std::filesystem::path dir =
      std::filesystem::path(HDRSTEREO_SOURCE_DIR) / "proto/hdrstereo/v1";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".proto") continue;
    const std::string name =
        absl::StrCat("hdrstereo/v1/", entry.path().filename().string());
    const google::protobuf::FileDescriptor* file =
        google::protobuf::DescriptorPool::generated_pool()->FindFileByName(
            name);
    EXPECT_NE(file, nullptr)
        << name
        << " is not in the generated pool: add one of its messages "
           "to AllProtoMethods() in tests/support/proto_methods.h";
    if (file == nullptr) continue;
    for (int s = 0; s < file->service_count(); ++s) {
      const google::protobuf::ServiceDescriptor* service = file->service(s);
      for (int m = 0; m < service->method_count(); ++m) {
        methods.push_back({absl::StrCat("/", service->full_name(), "/",
                                        service->method(m)->name()),
                           service->method(m)});
      }
    }
  }
  return methods;
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_PROTO_METHODS_H_
