// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/sessions_service.h"

#include <google/protobuf/util/time_util.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "daemon/rpc/pagination.h"
#include "daemon/rpc/status.h"
#include "daemon/store/artifact_repository.h"
#include "daemon/store/frame_repository.h"
#include "daemon/store/names.h"
#include "processing/pipeline/pipeline.h"
#include "processing/pipeline/session_files.h"

namespace hdrstereo::rpc {

namespace {

using google::protobuf::util::TimeUtil;

// Chunks well under gRPC's default 4 MiB message limit.
constexpr int64_t kChunkBytes = 1 << 20;

// A download's range as the request gives it, before anything is looked up.
grpc::Status CheckRangeFields(int64_t offset, int64_t length) {
  if (offset < 0) return InvalidArgument("offset_bytes must not be negative");
  if (length < 0) {
    return InvalidArgument(
        "length_bytes must not be negative (0 = to the end of the file)");
  }
  return grpc::Status::OK;
}

// A recorded file of a session to download.
struct DownloadedFile {
  std::filesystem::path path;
  std::string shown;  // its path in the session folder, for messages
  // The size the store recorded; nullopt when it recorded none (a frame's
  // file): the size on disk is the file's.
  std::optional<int64_t> recorded_size;
  std::string sha256;  // of the whole file, sent on every chunk
  const char* remedy;  // what a person can do when the file is gone
};

// Streams bytes [offset, offset + length) of `file` (length 0: to its end)
// in chunks: FAILED_PRECONDITION when the file is missing, DATA_LOSS when
// its size on disk is not the recorded one or it cannot be read through,
// OUT_OF_RANGE when the range ends beyond the file.
grpc::Status StreamFile(grpc::ServerContext& context,
                        const DownloadedFile& file, int64_t offset,
                        int64_t length,
                        grpc::ServerWriter<v1::ArtifactChunk>& writer) {
  std::ifstream in(file.path, std::ios::binary);
  std::error_code ec;
  const std::uintmax_t on_disk = std::filesystem::file_size(file.path, ec);
  if (!in || ec) {
    return grpc::Status(
        grpc::StatusCode::FAILED_PRECONDITION,
        absl::StrCat(file.shown, " is missing on disk; ", file.remedy));
  }
  const int64_t size = static_cast<int64_t>(on_disk);
  if (file.recorded_size.has_value() && size != *file.recorded_size) {
    return grpc::Status(
        grpc::StatusCode::DATA_LOSS,
        absl::StrCat(file.shown, " has ", size, " bytes on disk but ",
                     *file.recorded_size, " were recorded; ", file.remedy));
  }
  if (offset > size) {
    return grpc::Status(
        grpc::StatusCode::OUT_OF_RANGE,
        absl::StrCat("offset_bytes ", offset, " is beyond the end of ",
                     file.shown, " (", size, " bytes)"));
  }
  if (length > size - offset) {
    return grpc::Status(
        grpc::StatusCode::OUT_OF_RANGE,
        absl::StrCat("offset_bytes ", offset, " + length_bytes ", length,
                     " is beyond the end of ", file.shown, " (", size,
                     " bytes)"));
  }
  const int64_t end = length == 0 ? size : offset + length;
  std::string buffer(std::min(kChunkBytes, end - offset), '\0');
  in.seekg(offset);
  // At least one chunk, so that an empty range still says the size and
  // the sha256.
  do {
    if (context.IsCancelled()) {
      return grpc::Status(grpc::StatusCode::CANCELLED, "download cancelled");
    }
    const int64_t want = std::min(kChunkBytes, end - offset);
    in.read(buffer.data(), want);
    if (in.gcount() != want) {
      return grpc::Status(grpc::StatusCode::DATA_LOSS,
                          absl::StrCat("cannot read ", file.shown));
    }
    v1::ArtifactChunk chunk;
    chunk.set_offset_bytes(offset);
    chunk.set_data(buffer.data(), want);
    chunk.set_total_size_bytes(size);
    chunk.set_sha256(file.sha256);
    chunk.set_path(file.shown);
    if (!writer.Write(chunk)) {
      return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
    }
    offset += want;
  } while (offset < end);
  return grpc::Status::OK;
}

}  // namespace

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

grpc::Status SessionsService::Create(grpc::ServerContext* context,
                                     const v1::CreateSessionRequest* request,
                                     v1::Session* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<store::SessionRecord> record =
      sessions_.Create(request->name(), request->note());
  if (!record.ok()) return ToGrpcStatus(record.status());
  spdlog::info("session {}: created", record->name);
  ToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SessionsService::Get(grpc::ServerContext* context,
                                  const v1::GetSessionRequest* request,
                                  v1::Session* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<store::SessionRecord> record = sessions_.Get(request->name());
  if (!record.ok()) return ToGrpcStatus(record.status());
  ToProto(*record, response);
  return grpc::Status::OK;
}

grpc::Status SessionsService::List(grpc::ServerContext* context,
                                   const v1::ListSessionsRequest* request,
                                   v1::ListSessionsResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
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

grpc::Status SessionsService::Delete(grpc::ServerContext* context,
                                     const v1::DeleteSessionRequest* request,
                                     v1::DeleteSessionResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  absl::StatusOr<store::DeletedSession> deleted =
      sessions_.Delete(request->name());
  if (!deleted.ok()) return ToGrpcStatus(deleted.status());
  spdlog::info("session {}: deleted ({} frames, {} artifacts)", request->name(),
               deleted->frames, deleted->artifacts);
  response->set_frames_deleted(deleted->frames);
  response->set_artifacts_deleted(deleted->artifacts);
  return grpc::Status::OK;
}

grpc::Status SessionsService::ListArtifacts(
    grpc::ServerContext* context, const v1::ListArtifactsRequest* request,
    v1::ListArtifactsResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->kind().size() > 64) {
    return InvalidArgument("kind is longer than 64 bytes");
  }
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  absl::StatusOr<std::vector<store::ArtifactRecord>> artifacts =
      store::ArtifactRepository(store_).List(
          request->session(), request->kind(), page->after, page->size + 1);
  if (!artifacts.ok()) return ToGrpcStatus(artifacts.status());
  response->set_next_page_token(FinishIdPage(
      *page, *artifacts, [](const store::ArtifactRecord& a) { return a.id; }));
  for (const store::ArtifactRecord& a : *artifacts) {
    v1::Artifact* out = response->add_artifacts();
    out->set_id(a.id);
    out->set_kind(a.kind);
    out->set_path(a.path);
    out->set_params_json(a.params_json);
    out->set_sha256(a.sha256);
    out->set_size_bytes(a.size_bytes);
    out->set_job_id(a.job_id);
    *out->mutable_create_time() =
        google::protobuf::util::TimeUtil::MillisecondsToTimestamp(
            a.create_time_ms);
  }
  return grpc::Status::OK;
}

grpc::Status SessionsService::DownloadArtifact(
    grpc::ServerContext* context, const v1::DownloadArtifactRequest* request,
    grpc::ServerWriter<v1::ArtifactChunk>* writer) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->artifact_id() <= 0) {
    return InvalidArgument("artifact_id must be a positive artifact id");
  }
  if (grpc::Status s =
          CheckRangeFields(request->offset_bytes(), request->length_bytes());
      !s.ok()) {
    return s;
  }
  absl::StatusOr<store::ArtifactRecord> artifact =
      store::ArtifactRepository(store_).Get(request->session(),
                                            request->artifact_id());
  if (!artifact.ok()) return ToGrpcStatus(artifact.status());
  return StreamFile(
      *context,
      {.path = store_.files().SessionDir(request->session()) / artifact->path,
       .shown = artifact->path,
       .recorded_size = artifact->size_bytes,
       .sha256 = artifact->sha256,
       .remedy = "process the session again to recreate it"},
      request->offset_bytes(), request->length_bytes(), *writer);
}

grpc::Status SessionsService::DownloadFrame(
    grpc::ServerContext* context, const v1::DownloadFrameRequest* request,
    grpc::ServerWriter<v1::ArtifactChunk>* writer) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->frame_id() <= 0) {
    return InvalidArgument("frame_id must be a positive frame id");
  }
  if (grpc::Status s =
          CheckRangeFields(request->offset_bytes(), request->length_bytes());
      !s.ok()) {
    return s;
  }
  // The session's first frame from frame_id on: the frame, if it is one of
  // the session's.
  absl::StatusOr<std::vector<store::FrameRecord>> frames =
      store::FrameRepository(store_).FramesOfSession(
          request->session(), 0, request->frame_id() - 1, 1);
  if (!frames.ok()) return ToGrpcStatus(frames.status());
  if (frames->empty() || frames->front().id != request->frame_id()) {
    return grpc::Status(grpc::StatusCode::NOT_FOUND,
                        absl::StrCat("session ", request->session(),
                                     " has no frame ", request->frame_id()));
  }
  const store::FrameRecord& frame = frames->front();
  return StreamFile(
      *context,
      {.path = store_.files().SessionDir(request->session()) / frame.path,
       .shown = frame.path,
       .recorded_size = std::nullopt,
       .sha256 = frame.sha256,
       .remedy = "take the capture again"},
      request->offset_bytes(), request->length_bytes(), *writer);
}

grpc::Status SessionsService::ListMetrics(grpc::ServerContext* context,
                                          const v1::ListMetricsRequest* request,
                                          v1::ListMetricsResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  absl::StatusOr<store::SessionRecord> session =
      sessions_.Get(request->session());
  if (!session.ok()) return ToGrpcStatus(session.status());
  absl::StatusOr<std::vector<store::MetricRecord>> metrics =
      store::ArtifactRepository(store_).Metrics(session->id);
  if (!metrics.ok()) return ToGrpcStatus(metrics.status());
  std::vector<pipeline::Metric> rows;
  for (const store::MetricRecord& m : *metrics) {
    rows.push_back(
        {.method = m.method, .ground_truth = m.ground_truth, .rmse = m.rmse});
  }
  const std::vector<bool> worse = pipeline::WorseThanLdr(rows);
  for (size_t i = 0; i < metrics->size(); ++i) {
    const store::MetricRecord& m = (*metrics)[i];
    v1::Metric* out = response->add_metrics();
    out->set_method(m.method);
    out->set_ground_truth(m.ground_truth);
    out->set_rmse_px(m.rmse);
    out->set_mae_px(m.mae);
    out->set_bad_0_5(m.bad_0_5);
    out->set_bad_1(m.bad_1);
    out->set_bad_2(m.bad_2);
    out->set_bad_4(m.bad_4);
    out->set_coverage(m.coverage);
    out->set_job_id(m.job_id);
    out->set_worse_than_ldr(worse[i]);
  }
  return grpc::Status::OK;
}

grpc::Status SessionsService::ListFrames(grpc::ServerContext* context,
                                         const v1::ListFramesRequest* request,
                                         v1::ListFramesResponse* response) {
  if (grpc::Status s = calls_.Admit(*context); !s.ok()) return s;
  if (absl::Status s = store::ValidateName(request->session(), "session");
      !s.ok()) {
    return ToGrpcStatus(s);
  }
  if (request->capture_id() < 0) {
    return InvalidArgument("capture_id must be 0 (all) or a capture id");
  }
  absl::StatusOr<IdPage> page = ParseIdPage(request->page());
  if (!page.ok()) return ToGrpcStatus(page.status());
  absl::StatusOr<std::vector<store::FrameRecord>> frames =
      store::FrameRepository(store_).FramesOfSession(
          request->session(), request->capture_id(), page->after,
          page->size + 1);
  if (!frames.ok()) return ToGrpcStatus(frames.status());
  response->set_next_page_token(FinishIdPage(
      *page, *frames, [](const store::FrameRecord& f) { return f.id; }));
  for (const store::FrameRecord& f : *frames) {
    v1::Frame* out = response->add_frames();
    out->set_id(f.id);
    out->set_capture_id(f.capture_id);
    out->set_capture_kind(f.capture_kind == io::CaptureKind::kBracketedStereo
                              ? v1::CAPTURE_KIND_BRACKETED_STEREO
                          : f.capture_kind == io::CaptureKind::kStructuredLight
                              ? v1::CAPTURE_KIND_STRUCTURED_LIGHT
                              : v1::CAPTURE_KIND_CALIBRATION);
    out->set_sequence(f.sequence);
    out->set_view_index(f.view_index);
    out->set_stage_position_mm(f.stage_position_mm);
    out->set_exposure_s(f.exposure_s);
    out->set_pattern(f.pattern);
    out->set_inverse(f.inverse);
    static const std::map<hardware::ImageFormat, v1::ImageFormat> kFormats = {
        {hardware::ImageFormat::kJpeg, v1::IMAGE_FORMAT_JPEG},
        {hardware::ImageFormat::kRaw, v1::IMAGE_FORMAT_RAW},
        {hardware::ImageFormat::kRawAndJpeg, v1::IMAGE_FORMAT_RAW_AND_JPEG},
        {hardware::ImageFormat::kTiff16, v1::IMAGE_FORMAT_TIFF_16},
        {hardware::ImageFormat::kPng8, v1::IMAGE_FORMAT_PNG_8}};
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
    if (f.camera_exposure_s) out->set_camera_exposure_s(*f.camera_exposure_s);
    if (f.iso) out->set_iso(*f.iso);
    if (f.aperture_f) out->set_aperture_f(*f.aperture_f);
    out->set_camera_file_name(f.camera_file_name);
  }
  return grpc::Status::OK;
}

}  // namespace hdrstereo::rpc
