// SPDX-License-Identifier: GPL-3.0-or-later
#ifndef HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_

#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "daemon/jobs/rig_lock.h"
#include "daemon/rpc/authenticator.h"
#include "hardware/rig.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"

namespace hdrstereo::rpc {

// Direct control of the rig, and its lock. Every request is validated
// before any device is touched; calls that act on a device are refused
// while a capture holds the hardware lane (and, by CallGuard, while another
// principal holds the rig lock).
class HardwareService final : public v1::Hardware::Service {
 public:
  HardwareService(hardware::Rig& rig, jobs::RigLock& lock,
                  Authenticator& authenticator)
      : rig_(rig), lock_(lock), authenticator_(authenticator) {}

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

  hardware::Rig& rig_;
  jobs::RigLock& lock_;
  Authenticator& authenticator_;
  absl::Mutex showing_mutex_;
  // What this service last showed.
  std::string showing_ ABSL_GUARDED_BY(showing_mutex_) = "blank";
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_HARDWARE_SERVICE_H_
