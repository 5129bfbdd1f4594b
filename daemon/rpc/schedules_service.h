// SPDX-License-Identifier: GPL-3.0-or-later
//
// Schedules: create, list (with next due times), delete, enable/disable and
// the run history. Validation happens here, before anything is stored.
#ifndef HDRSTEREO_DAEMON_RPC_SCHEDULES_SERVICE_H_
#define HDRSTEREO_DAEMON_RPC_SCHEDULES_SERVICE_H_

#include "daemon/jobs/scheduler.h"
#include "daemon/rpc/call_guard_interceptor.h"
#include "hardware/rig.h"
#include "hdrstereo/v1/schedules.grpc.pb.h"

namespace hdrstereo::rpc {

class SchedulesService final : public v1::Schedules::Service {
 public:
  SchedulesService(jobs::Scheduler& scheduler, const hardware::Rig& rig,
                   const CallDecisions& calls)
      : scheduler_(scheduler), rig_(rig), calls_(calls) {}

  grpc::Status Create(grpc::ServerContext* context,
                      const v1::CreateScheduleRequest* request,
                      v1::Schedule* response) override;
  grpc::Status List(grpc::ServerContext* context,
                    const v1::ListSchedulesRequest* request,
                    v1::ListSchedulesResponse* response) override;
  grpc::Status Delete(grpc::ServerContext* context,
                      const v1::DeleteScheduleRequest* request,
                      v1::DeleteScheduleResponse* response) override;
  grpc::Status SetEnabled(grpc::ServerContext* context,
                          const v1::SetScheduleEnabledRequest* request,
                          v1::Schedule* response) override;
  grpc::Status ListRuns(grpc::ServerContext* context,
                        const v1::ListScheduleRunsRequest* request,
                        v1::ListScheduleRunsResponse* response) override;

 private:
  void ToProto(const store::ScheduleRecord& record, v1::Schedule* out);

  jobs::Scheduler& scheduler_;
  const hardware::Rig& rig_;
  const CallDecisions& calls_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_SCHEDULES_SERVICE_H_
