// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/sessions_service.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include <map>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "daemon/rpc/pagination.h"
#include "daemon/rpc/status.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/names.h"

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

grpc::Status SessionsService::ListFrames(grpc::ServerContext*,
                                         const v1::ListFramesRequest* request,
                                         v1::ListFramesResponse* response) {
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->capture_id() < 0) {
    return InvalidArgument("capture_id must be 0 (all) or a capture id");
  }
  absl::StatusOr<Page> page = ParsePage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  int64_t after = 0;
  if (!page->after.empty() && !absl::SimpleAtoi(page->after, &after)) {
    return InvalidArgument("page.page_token was not issued by this server");
  }
  absl::StatusOr<std::vector<store::FrameRecord>> frames =
      store::FrameRepository(store_).FramesOfSession(
          request->session(), request->capture_id(), after, page->size + 1);
  if (!frames.ok()) return ToGrpcStatus(frames.status());
  if (static_cast<int>(frames->size()) > page->size) {
    frames->pop_back();
    response->set_next_page_token(
        EncodePageToken(absl::StrCat(frames->back().id)));
  }
  for (const store::FrameRecord& f : *frames) {
    v1::Frame* out = response->add_frames();
    out->set_id(f.id);
    out->set_capture_id(f.capture_id);
    out->set_capture_kind(f.capture_kind == "bracketed_stereo"
                              ? v1::CAPTURE_KIND_BRACKETED_STEREO
                          : f.capture_kind == "structured_light"
                              ? v1::CAPTURE_KIND_STRUCTURED_LIGHT
                              : v1::CAPTURE_KIND_CALIBRATION);
    out->set_sequence(f.sequence);
    out->set_view_index(f.view_index);
    out->set_stage_position_mm(f.stage_position_mm);
    out->set_exposure_s(f.exposure_s);
    out->set_pattern(f.pattern);
    out->set_inverse(f.inverse);
    static const std::map<std::string, v1::ImageFormat> kFormats = {
        {"jpeg", v1::IMAGE_FORMAT_JPEG},
        {"raw", v1::IMAGE_FORMAT_RAW},
        {"raw+jpeg", v1::IMAGE_FORMAT_RAW_AND_JPEG},
        {"tiff16", v1::IMAGE_FORMAT_TIFF_16},
        {"png8", v1::IMAGE_FORMAT_PNG_8}};
    auto format = kFormats.find(f.format);
    out->set_format(format != kFormats.end() ? format->second
                                             : v1::IMAGE_FORMAT_UNSPECIFIED);
    out->set_width_px(f.width_px);
    out->set_height_px(f.height_px);
    out->set_path(f.path);
    out->set_sha256(f.sha256);
    if (f.camera_time_ms) {
      *out->mutable_camera_time() =
          TimeUtil::MillisecondsToTimestamp(*f.camera_time_ms);
    }
  }
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
