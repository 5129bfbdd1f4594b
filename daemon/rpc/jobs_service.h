// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_JOBS_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_JOBS_SERVICE_H_

#include "daemon/jobs/disk_guard.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/jobs/processing_job.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "hardware/rig.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"

namespace hdrstereo::rpc {

// Jobs: submit captures and processing (recording who submitted them),
// follow and steer jobs.
class JobsService final : public v1::Jobs::Service {
 public:
  JobsService(jobs::JobEngine& engine, hardware::Rig& rig,
              const jobs::ProcessingEnvironment& processing,
              const jobs::DiskGuard& disk, const CallDecisions& calls)
      : engine_(engine),
        rig_(rig),
        processing_(processing),
        disk_(disk),
        calls_(calls) {}

  grpc::Status SubmitCapture(grpc::ServerContext* context,
                             const v1::SubmitCaptureRequest* request,
                             v1::Job* response) override;
  grpc::Status EstimateCapture(grpc::ServerContext* context,
                               const v1::EstimateCaptureRequest* request,
                               v1::CaptureEstimate* response) override;
  grpc::Status SubmitProcessing(grpc::ServerContext* context,
                                const v1::SubmitProcessingRequest* request,
                                v1::Job* response) override;
  grpc::Status SubmitProcessingBatch(
      grpc::ServerContext* context,
      const v1::SubmitProcessingBatchRequest* request,
      v1::SubmitProcessingBatchResponse* response) override;
  grpc::Status Get(grpc::ServerContext* context,
                   const v1::GetJobRequest* request,
                   v1::Job* response) override;
  grpc::Status List(grpc::ServerContext* context,
                    const v1::ListJobsRequest* request,
                    v1::ListJobsResponse* response) override;
  grpc::Status Watch(grpc::ServerContext* context,
                     const v1::WatchJobRequest* request,
                     grpc::ServerWriter<v1::JobEvent>* writer) override;
  grpc::Status Pause(grpc::ServerContext* context,
                     const v1::PauseJobRequest* request,
                     v1::Job* response) override;
  grpc::Status Resume(grpc::ServerContext* context,
                      const v1::ResumeJobRequest* request,
                      v1::Job* response) override;
  grpc::Status Cancel(grpc::ServerContext* context,
                      const v1::CancelJobRequest* request,
                      v1::Job* response) override;
  grpc::Status Continue(grpc::ServerContext* context,
                        const v1::ContinueJobRequest* request,
                        v1::Job* response) override;

 private:
  jobs::JobEngine& engine_;
  hardware::Rig& rig_;
  const jobs::ProcessingEnvironment& processing_;
  const jobs::DiskGuard& disk_;
  const CallDecisions& calls_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_JOBS_SERVICE_H_
