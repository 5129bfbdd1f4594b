// SPDX-License-Identifier: GPL-3.0-or-later
//
// Routes to methods and bodies to messages: every method of every
// hdrstereo.v1 service is on HTTP (walking the generated descriptor pool,
// so a new RPC is tested the day it is added), other paths are 404 or
// unimplemented, and JSON and binary bodies become request bytes, or an
// INVALID_ARGUMENT naming what is wrong.
#include "daemon/http/rpc_routes.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "hdrstereo/v1/jobs.pb.h"
#include "hdrstereo/v1/sessions.pb.h"
#include "tests/support/proto_methods.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::http {
namespace {

using ::hdrstereo::testing::AllProtoMethods;
using ::hdrstereo::testing::ProtoMethod;
using ::hdrstereo::testing::StatusIs;
using ::testing::AllOf;
using ::testing::AnyOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

TEST(FindRpcMethodTest, EveryMethodOfEveryServiceHasItsRoute) {
  const std::vector<ProtoMethod> methods = AllProtoMethods();
  ASSERT_FALSE(methods.empty());
  bool saw_server_stream = false;
  for (const ProtoMethod& method : methods) {
    ASSERT_OK_AND_ASSIGN(RpcMethod found, FindRpcMethod(method.full_name));
    EXPECT_EQ(found.descriptor, method.descriptor) << method.full_name;
    EXPECT_EQ(found.grpc_path, method.full_name);
    saw_server_stream |= method.descriptor->server_streaming();
  }
  // The streams (Jobs.Watch, Hardware.StreamPreview) are served too.
  EXPECT_TRUE(saw_server_stream);
}

TEST(FindRpcMethodTest, AnUnknownServiceOrMethodIsUnimplemented) {
  for (const char* path :
       {"/hdrstereo.v1.Jobs/Nope", "/hdrstereo.v1.Nope/Get",
        "/hdrstereo.v1.jobs/get", "/hdrstereo.v1.Jobs/get",
        "/hdrstereo.v1.Jobs.Sub/Get", "/hdrstereo.v1.Jobs/Get?x=1",
        "/hdrstereo.v1.v1.Jobs/Get"}) {
    EXPECT_THAT(
        FindRpcMethod(path),
        StatusIs(absl::StatusCode::kUnimplemented,
                 absl::StrCat("hdrstereod serves no method \"", path, "\"")));
  }
  EXPECT_THAT(FindRpcMethod(std::string("/hdrstereo.v1.Jobs/Get\0x", 24)),
              StatusIs(absl::StatusCode::kUnimplemented,
                       "hdrstereod serves no method "
                       "\"/hdrstereo.v1.Jobs/Get\\x00x\""));
}

TEST(FindRpcMethodTest, OtherPathsAreNotFound) {
  // Not a route into the package at all.
  for (const char* path :
       {"", "/", "/index.html", "hdrstereo.v1.Jobs/Get",
        "/hdrstereo.v2.Jobs/Get", "/hdrstereo.v1Jobs/Get",
        "/grpc.reflection.v1alpha.ServerReflection/ServerReflectionInfo",
        "/grpc.health.v1.Health/Check", "//hdrstereo.v1.Jobs/Get"}) {
    EXPECT_THAT(FindRpcMethod(path),
                StatusIs(absl::StatusCode::kNotFound,
                         absl::StrCat("no such page: \"", path, "\"")));
  }
  // Into the package, but not /<Service>/<Method>.
  for (const char* path :
       {"/hdrstereo.v1.Jobs", "/hdrstereo.v1.Jobs/", "/hdrstereo.v1./Get",
        "/hdrstereo.v1.", "/hdrstereo.v1.Jobs/Get/", "/hdrstereo.v1.Jobs/Get/x",
        "/hdrstereo.v1.Jobs//Get", "/hdrstereo.v1.//"}) {
    EXPECT_THAT(FindRpcMethod(path),
                StatusIs(absl::StatusCode::kNotFound,
                         absl::StrCat("no such page: \"", path,
                                      "\" (methods are at "
                                      "/hdrstereo.v1.<Service>/<Method>)")));
  }
}

TEST(FindRpcMethodTest, AHugePathIsQuotedBounded) {
  const std::string path = "/hdrstereo.v1.Jobs/" + std::string(10000, 'x');
  EXPECT_THAT(FindRpcMethod(path),
              StatusIs(absl::StatusCode::kUnimplemented,
                       AllOf(StartsWith("hdrstereod serves no method "
                                        "\"/hdrstereo.v1.Jobs/xxx"),
                             HasSubstr("\"... (10019 bytes)"))));
}

RpcMethod Method(absl::string_view path) {
  absl::StatusOr<RpcMethod> method = FindRpcMethod(path);
  EXPECT_OK(method);
  return method.ok() ? *method : RpcMethod{};
}

TEST(RequestBytesTest, JsonBecomesTheRequestMessage) {
  const RpcMethod get = Method("/hdrstereo.v1.Jobs/Get");
  for (const char* body : {R"({"jobId": "42"})", R"({"jobId": 42})",
                           R"({"job_id": 42})", " \n{\"jobId\":42}\n"}) {
    ASSERT_OK_AND_ASSIGN(std::string bytes,
                         RequestBytes(get, Codec::kJson, body));
    v1::GetJobRequest request;
    ASSERT_TRUE(request.ParseFromString(bytes)) << body;
    EXPECT_EQ(request.job_id(), 42) << body;
  }
  const RpcMethod list = Method("/hdrstereo.v1.Jobs/List");
  ASSERT_OK_AND_ASSIGN(
      std::string bytes,
      RequestBytes(list, Codec::kJson,
                   R"({"session": "s1", "states": ["JOB_STATE_RUNNING", 4],
                       "page": {"pageSize": 10, "pageToken": "t"}})"));
  v1::ListJobsRequest request;
  ASSERT_TRUE(request.ParseFromString(bytes));
  EXPECT_EQ(request.session(), "s1");
  ASSERT_EQ(request.states_size(), 2);
  EXPECT_EQ(request.states(0), v1::JOB_STATE_RUNNING);
  EXPECT_EQ(request.states(1), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(request.page().page_size(), 10);
  EXPECT_EQ(request.page().page_token(), "t");
}

TEST(RequestBytesTest, AnEmptyBodyIsTheEmptyMessage) {
  const RpcMethod list = Method("/hdrstereo.v1.Sessions/List");
  for (const char* body : {"", " \r\n\t", "{}"}) {
    ASSERT_OK_AND_ASSIGN(std::string bytes,
                         RequestBytes(list, Codec::kJson, body));
    EXPECT_EQ(bytes, "") << body;
  }
  ASSERT_OK_AND_ASSIGN(std::string bytes,
                       RequestBytes(list, Codec::kProto, ""));
  EXPECT_EQ(bytes, "");
}

TEST(RequestBytesTest, AnUnknownFieldIsRefusedByName) {
  EXPECT_THAT(RequestBytes(Method("/hdrstereo.v1.Jobs/Get"), Codec::kJson,
                           R"({"jobId": 1, "jobIdentifier": 2})"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(StartsWith("the body is not a JSON "
                                        "hdrstereo.v1.GetJobRequest: "),
                             HasSubstr("jobIdentifier"))));
  // In a nested message too.
  EXPECT_THAT(RequestBytes(Method("/hdrstereo.v1.Sessions/List"), Codec::kJson,
                           R"({"page": {"pageSize": 1, "limit": 5}})"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(StartsWith("the body is not a JSON "
                                        "hdrstereo.v1.ListSessionsRequest: "),
                             HasSubstr("limit"))));
}

TEST(RequestBytesTest, AValueOfTheWrongTypeIsRefusedNamingTheField) {
  const RpcMethod get = Method("/hdrstereo.v1.Jobs/Get");
  for (const char* body :
       {R"({"jobId": "forty-two"})", R"({"jobId": 1.5})", R"({"jobId": {}})",
        R"({"jobId": [1]})", R"({"jobId": true})",
        R"({"jobId": "9223372036854775808"})"}) {
    EXPECT_THAT(RequestBytes(get, Codec::kJson, body),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         AllOf(StartsWith("the body is not a JSON "
                                          "hdrstereo.v1.GetJobRequest: "),
                               AnyOf(HasSubstr("job_id"), HasSubstr("jobId")))))
        << body;
  }
  EXPECT_THAT(RequestBytes(Method("/hdrstereo.v1.Jobs/List"), Codec::kJson,
                           R"({"states": ["JOB_STATE_NAPPING"]})"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       AllOf(StartsWith("the body is not a JSON "
                                        "hdrstereo.v1.ListJobsRequest: "),
                             HasSubstr("states"))));
}

TEST(RequestBytesTest, AnObjectForANumberNamesTheFieldToo) {
  // Protobuf names the field at the end of this message, after 70 bytes of
  // text: once cut off by the 64 bytes QuoteInput keeps by default.
  EXPECT_THAT(
      RequestBytes(Method("/hdrstereo.v1.Sessions/List"), Codec::kJson,
                   R"({"page": {"pageSize": {}}})"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               "the body is not a JSON hdrstereo.v1.ListSessionsRequest: "
               "\"(page): invalid value Starting an object on a scalar field "
               "for type page_size\""));
}

TEST(RequestBytesTest, MalformedJsonIsRefused) {
  const RpcMethod get = Method("/hdrstereo.v1.Jobs/Get");
  for (const char* body :
       {"{", "}", "[1]", "42", "\"x\"", "not json", R"({"jobId" 1})",
        R"({"jobId": 1} {"jobId": 2})", "{\"jobId\": 1\x01}", "\xff\xfe{}"}) {
    EXPECT_THAT(RequestBytes(get, Codec::kJson, body),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         StartsWith("the body is not a JSON "
                                    "hdrstereo.v1.GetJobRequest: \"")))
        << body;
  }
}

TEST(RequestBytesTest, StringsThatAreNotUtf8AreRefused) {
  // What protobuf would serialize but the gRPC side could not parse back.
  const RpcMethod list = Method("/hdrstereo.v1.Jobs/List");
  for (const char* body :
       {"{\"session\": \"\xff\"}", "{\"session\": \"\xc3\"}",
        R"({"session": "\udc00"})", R"({"session": "\ud800"})"}) {
    EXPECT_THAT(RequestBytes(list, Codec::kJson, body),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         StartsWith("the body is not a JSON "
                                    "hdrstereo.v1.ListJobsRequest: \"")))
        << body;
  }
  v1::ListJobsRequest request;
  request.set_session("\xff");  // serialized as it is, with a complaint
  EXPECT_THAT(RequestBytes(list, Codec::kProto, request.SerializeAsString()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "the body is not a binary hdrstereo.v1.ListJobsRequest "
                       "message"));
}

TEST(RequestBytesTest, ProtobufsMessageIsQuotedBounded) {
  const std::string field(5000, 'f');
  absl::StatusOr<std::string> bytes =
      RequestBytes(Method("/hdrstereo.v1.Jobs/Get"), Codec::kJson,
                   absl::StrCat("{\"", field, "\": 1}"));
  EXPECT_THAT(bytes, StatusIs(absl::StatusCode::kInvalidArgument,
                              HasSubstr(" bytes)")));
  EXPECT_LT(bytes.status().message().size(), 400u);
}

TEST(RequestBytesTest, BinaryBodiesAreCheckedByParsing) {
  const RpcMethod get = Method("/hdrstereo.v1.Jobs/Get");
  v1::GetJobRequest request;
  request.set_job_id(7);
  ASSERT_OK_AND_ASSIGN(
      std::string bytes,
      RequestBytes(get, Codec::kProto, request.SerializeAsString()));
  EXPECT_EQ(bytes, request.SerializeAsString());
  // A truncated varint, a bad wire type, a length past the end, a group
  // that never ends.
  for (const std::string& body :
       {std::string("\x08\xff", 2), std::string("\x0f", 1),
        std::string("\x12\x10xy", 4), std::string("\x0b", 1),
        std::string("\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff\xff", 11)}) {
    EXPECT_THAT(RequestBytes(get, Codec::kProto, body),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         "the body is not a binary hdrstereo.v1.GetJobRequest "
                         "message"));
  }
}

TEST(ResponseBodyTest, JsonHasLowerCamelCaseNamesAndInt64AsStrings) {
  const RpcMethod get = Method("/hdrstereo.v1.Jobs/Get");
  v1::Job job;
  job.set_id(42);
  job.set_session("s1");
  job.set_state(v1::JOB_STATE_RUNNING);
  job.mutable_create_time()->set_seconds(1'800'000'000);
  ASSERT_OK_AND_ASSIGN(std::string json, ResponseBody(get, Codec::kJson,
                                                      job.SerializeAsString()));
  EXPECT_EQ(json, R"({"id":"42","session":"s1","state":"JOB_STATE_RUNNING",)"
                  R"("createTime":"2027-01-15T08:00:00Z"})");
  v1::ListSessionsResponse sessions;
  sessions.set_next_page_token("p2");
  ASSERT_OK_AND_ASSIGN(
      json, ResponseBody(Method("/hdrstereo.v1.Sessions/List"), Codec::kJson,
                         sessions.SerializeAsString()));
  EXPECT_EQ(json, R"({"nextPageToken":"p2"})");
}

TEST(ResponseBodyTest, BinaryIsTheBytesAsTheyAre) {
  v1::Job job;
  job.set_id(42);
  ASSERT_OK_AND_ASSIGN(std::string body,
                       ResponseBody(Method("/hdrstereo.v1.Jobs/Get"),
                                    Codec::kProto, job.SerializeAsString()));
  EXPECT_EQ(body, job.SerializeAsString());
}

TEST(ResponseBodyTest, BytesThatAreNotTheOutputTypeAreInternal) {
  EXPECT_THAT(ResponseBody(Method("/hdrstereo.v1.Jobs/Get"), Codec::kJson,
                           std::string("\x08\xff", 2)),
              StatusIs(absl::StatusCode::kInternal,
                       "/hdrstereo.v1.Jobs/Get answered with bytes that are "
                       "not a hdrstereo.v1.Job"));
}

}  // namespace
}  // namespace hdrstereo::http
