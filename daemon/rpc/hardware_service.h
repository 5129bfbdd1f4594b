// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_

#include <mutex>
#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/synchronization/mutex.h"
#include "daemon/jobs/job_engine.h"
#include "daemon/jobs/rig_calibration.h"
#include "daemon/jobs/rig_lock.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "hardware/rig.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"

namespace hdrstereo::rpc {

// Direct control of the rig, live view and its lock. Every request is
// validated before any device is touched; calls that act on a device are
// refused, naming the job, while a capture job runs on the hardware lane
// (and, by the guard, while another principal holds the rig lock). They
// take the lane for each device call only, so they wait for one another
// (and for a live-view frame) rather than fail.
class HardwareService final : public v1::Hardware::Service {
 public:
  // Live view frames at most this often (and kDefaultPreviewFps when the
  // request does not say).
  static constexpr double kMaxPreviewFps = 10;
  static constexpr double kDefaultPreviewFps = 5;
  // How long a call waits for another direct call or live-view frame that
  // holds the lane.
  static constexpr absl::Duration kLaneWait = absl::Seconds(15);

  HardwareService(hardware::Rig& rig, jobs::RigLock& lock,
                  const CallDecisions& calls, jobs::JobEngine& engine)
      : rig_(rig),
        lock_(lock),
        calls_(calls),
        engine_(engine),
        guide_(engine.store()) {}

  grpc::Status GetStatus(grpc::ServerContext* context,
                         const v1::GetHardwareStatusRequest* request,
                         v1::HardwareStatus* response) override;
  grpc::Status GetCameraSettings(grpc::ServerContext* context,
                                 const v1::GetCameraSettingsRequest* request,
                                 v1::CameraSettings* response) override;
  grpc::Status SetCameraSettings(grpc::ServerContext* context,
                                 const v1::SetCameraSettingsRequest* request,
                                 v1::CameraSettings* response) override;
  grpc::Status HomeStage(grpc::ServerContext* context,
                         const v1::HomeStageRequest* request,
                         v1::StageStatus* response) override;
  grpc::Status MoveStage(grpc::ServerContext* context,
                         const v1::MoveStageRequest* request,
                         v1::StageStatus* response) override;
  grpc::Status ShowPattern(grpc::ServerContext* context,
                           const v1::ShowPatternRequest* request,
                           v1::ProjectorStatus* response) override;
  grpc::Status BlankProjector(grpc::ServerContext* context,
                              const v1::BlankProjectorRequest* request,
                              v1::ProjectorStatus* response) override;
  grpc::Status StreamPreview(
      grpc::ServerContext* context, const v1::StreamPreviewRequest* request,
      grpc::ServerWriter<v1::PreviewMessage>* writer) override;
  grpc::Status ProbeProjector(grpc::ServerContext* context,
                              const v1::ProbeProjectorRequest* request,
                              v1::ProjectorProbe* response) override;
  grpc::Status Lock(grpc::ServerContext* context,
                    const v1::LockRequest* request,
                    v1::RigLock* response) override;
  grpc::Status Unlock(grpc::ServerContext* context,
                      const v1::UnlockRequest* request,
                      v1::RigLock* response) override;
  grpc::Status GetLock(grpc::ServerContext* context,
                       const v1::GetLockRequest* request,
                       v1::RigLock* response) override;

 private:
  void FillCamera(v1::CameraStatus* out);
  void FillStage(v1::StageStatus* out);
  void FillProjector(v1::ProjectorStatus* out);
  // "capture job 12 (session lab)".
  std::string DescribeJob(int64_t job_id);
  // FAILED_PRECONDITION naming the capture job on the hardware lane, or OK.
  // With `allow_waiting`, a capture job that waits for the operator (a
  // calibration between board poses, which lets go of the rig meanwhile)
  // does not count: live view shows the board while it is placed.
  absl::Status CheckNoCapture(bool allow_waiting = false);
  // The capture job that holds the rig for live view: the running one,
  // unless it waits for the operator; 0 for none.
  int64_t CaptureHoldingRigForPreview();
  // The hardware lane for one call: waits (up to `wait`) while another
  // call holds it; FAILED_PRECONDITION while a capture job runs.
  absl::StatusOr<std::unique_lock<std::mutex>> TakeLane(
      bool allow_waiting, absl::Duration wait = kLaneWait);
  // One live-view frame with its statistics (under the lane).
  absl::StatusOr<v1::PreviewFrame> TakePreviewFrame();
  // While a calibration capture waits for a pose: what `frame` shows of
  // the board and what the poses kept so far cover (frame->calibration).
  void GuideCalibration(v1::PreviewFrame* frame);

  hardware::Rig& rig_;
  jobs::RigLock& lock_;
  const CallDecisions& calls_;
  jobs::JobEngine& engine_;
  jobs::CalibrationGuide guide_;
  absl::Mutex showing_mutex_;
  // What this service last showed.
  std::string showing_ ABSL_GUARDED_BY(showing_mutex_) = "blank";
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_
