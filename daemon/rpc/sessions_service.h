// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_SESSIONS_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_SESSIONS_SERVICE_H_

#include "daemon/rpc/call_guard_interceptor.h"
#include "daemon/store/session_repository.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"

namespace hdrstereo::rpc {

// Sessions: create, read and delete sessions; list their frames, the
// artifacts and metrics processing recorded; stream an artifact's or a
// frame's bytes.
class SessionsService final : public v1::Sessions::Service {
 public:
  SessionsService(store::Store& store, const CallDecisions& calls)
      : store_(store), calls_(calls), sessions_(store) {}

  grpc::Status Create(grpc::ServerContext* context,
                      const v1::CreateSessionRequest* request,
                      v1::Session* response) override;
  grpc::Status Get(grpc::ServerContext* context,
                   const v1::GetSessionRequest* request,
                   v1::Session* response) override;
  grpc::Status List(grpc::ServerContext* context,
                    const v1::ListSessionsRequest* request,
                    v1::ListSessionsResponse* response) override;
  grpc::Status Delete(grpc::ServerContext* context,
                      const v1::DeleteSessionRequest* request,
                      v1::DeleteSessionResponse* response) override;
  grpc::Status ListArtifacts(grpc::ServerContext* context,
                             const v1::ListArtifactsRequest* request,
                             v1::ListArtifactsResponse* response) override;
  grpc::Status DownloadArtifact(
      grpc::ServerContext* context, const v1::DownloadArtifactRequest* request,
      grpc::ServerWriter<v1::ArtifactChunk>* writer) override;
  grpc::Status DownloadFrame(
      grpc::ServerContext* context, const v1::DownloadFrameRequest* request,
      grpc::ServerWriter<v1::ArtifactChunk>* writer) override;
  grpc::Status ListMetrics(grpc::ServerContext* context,
                           const v1::ListMetricsRequest* request,
                           v1::ListMetricsResponse* response) override;
  grpc::Status ListFrames(grpc::ServerContext* context,
                          const v1::ListFramesRequest* request,
                          v1::ListFramesResponse* response) override;

 private:
  void ToProto(const store::SessionRecord& record, v1::Session* out) const;

  store::Store& store_;
  const CallDecisions& calls_;
  store::SessionRepository sessions_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_SESSIONS_SERVICE_H_
