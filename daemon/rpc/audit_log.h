// SPDX-License-Identifier: GPL-3.0-or-later
//
// Writes audit rows to SQLite on a thread of its own, in batches: a call
// (or a flood of refused calls) never waits for the disk, and gRPC's
// authentication runs on its transport threads, where blocking is not
// allowed. Flush() makes everything recorded so far readable (ListAuditLog
// flushes first); the destructor flushes. What a crash of the process cuts
// off is at most the batch being written (milliseconds of calls).
#ifndef HDRSTEREO_DAEMON_RPC_AUDIT_LOG_H_
#define HDRSTEREO_DAEMON_RPC_AUDIT_LOG_H_

#include <cstdint>
#include <deque>
#include <thread>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"
#include "daemon/store/audit_repository.h"

namespace hdrstereo::rpc {

class AuditLog {
 public:
  explicit AuditLog(store::Store& store);
  ~AuditLog();
  AuditLog(const AuditLog&) = delete;
  AuditLog& operator=(const AuditLog&) = delete;

  // Queues a row (time_ms 0 = now). Beyond kMaxQueued rows waiting, rows are
  // counted and dropped, and one row says how many were.
  void Record(store::AuditRecord record) ABSL_LOCKS_EXCLUDED(mutex_);
  // Returns when every row recorded before the call is in SQLite.
  void Flush() ABSL_LOCKS_EXCLUDED(mutex_);

  store::AuditRepository& repository() { return repository_; }

  static constexpr size_t kMaxQueued = 100000;

 private:
  void WriterLoop() ABSL_LOCKS_EXCLUDED(mutex_);

  store::AuditRepository repository_;
  absl::Mutex mutex_;
  absl::CondVar work_cv_;
  absl::CondVar done_cv_;
  std::deque<store::AuditRecord> queue_ ABSL_GUARDED_BY(mutex_);
  // Rows handed to Record().
  int64_t recorded_ ABSL_GUARDED_BY(mutex_) = 0;
  // Of those, rows the writer has finished with.
  int64_t written_ ABSL_GUARDED_BY(mutex_) = 0;
  // Dropped since the last note about it.
  int64_t dropped_ ABSL_GUARDED_BY(mutex_) = 0;
  bool stopping_ ABSL_GUARDED_BY(mutex_) = false;
  std::thread writer_;
};

}  // namespace hdrstereo::rpc

#endif  // HDRSTEREO_DAEMON_RPC_AUDIT_LOG_H_
