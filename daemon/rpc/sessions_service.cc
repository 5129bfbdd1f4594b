// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/sessions_service.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include "daemon/rpc/pagination.h"
#include "daemon/rpc/status.h"

namespace hdrstereo::rpc {

using google::protobuf::util::TimeUtil;

void SessionsService::ToProto(const store::SessionRecord& record,
                              v1::Session* out) const {
  out->set_name(record.name);
  out->set_note(record.note);
  *out->mutable_create_time() =
      TimeUtil::MillisecondsToTimestamp(record.create_time_ms);
  out->set_path(store_.files().SessionDir(record.name).string());
  out->set_capture_count(record.capture_count);
  out->set_frame_count(record.frame_count);
  out->set_artifact_count(record.artifact_count);
}

grpc::Status SessionsService::Create(grpc::ServerContext*,
                                     const v1::CreateSessionRequest* request,
                                     v1::Session* response) {
  absl::StatusOr<store::SessionRecord> record =
      sessions_.Create(request->name(), request->note());
  if (!record.ok()) return ToGrpcStatus(record.status());
  spdlog::info("session {}: created", record->name);
  ToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SessionsService::Get(grpc::ServerContext*,
                                  const v1::GetSessionRequest* request,
                                  v1::Session* response) {
  absl::StatusOr<store::SessionRecord> record = sessions_.Get(request->name());
  if (!record.ok()) return ToGrpcStatus(record.status());
  ToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SessionsService::List(grpc::ServerContext*,
                                   const v1::ListSessionsRequest* request,
                                   v1::ListSessionsResponse* response) {
  absl::StatusOr<Page> page = ParsePage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  absl::StatusOr<store::SessionPage> result =
      sessions_.List(page->after, page->size);
  if (!result.ok()) return ToGrpcStatus(result.status());
  for (const store::SessionRecord& record : result->sessions) {
    ToProto(record, response->add_sessions());
  }
  response->set_next_page_token(EncodePageToken(result->next_after));
  return grpc::Status::OK;
}

grpc::Status SessionsService::Delete(grpc::ServerContext*,
                                     const v1::DeleteSessionRequest* request,
                                     v1::DeleteSessionResponse* response) {
  absl::StatusOr<store::DeletedSession> deleted =
      sessions_.Delete(request->name());
  if (!deleted.ok()) return ToGrpcStatus(deleted.status());
  spdlog::info("session {}: deleted ({} frames, {} artifacts)", request->name(),
               deleted->frames, deleted->artifacts);
  response->set_frames_deleted(deleted->frames);
  response->set_artifacts_deleted(deleted->artifacts);
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
