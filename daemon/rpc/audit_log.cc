// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/rpc/audit_log.h"

#include <spdlog/spdlog.h>

#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"

namespace hdrstereo::rpc {
namespace {
constexpr size_t kBatch = 1000;  // rows per transaction
}  // namespace

AuditLog::AuditLog(store::Store& store)
    : repository_(store), writer_([this] { WriterLoop(); }) {}

AuditLog::~AuditLog() {
  {
    absl::MutexLock lock(&mutex_);
    stopping_ = true;
    work_cv_.SignalAll();
  }
  writer_.join();
}

void AuditLog::Record(store::AuditRecord record) {
  if (record.time_ms == 0) record.time_ms = absl::ToUnixMillis(absl::Now());
  absl::MutexLock lock(&mutex_);
  ++recorded_;
  if (queue_.size() >= kMaxQueued) {
    ++dropped_;
    ++written_;  // nothing left to wait for
    return;
  }
  queue_.push_back(std::move(record));
  work_cv_.Signal();
}

void AuditLog::Flush() {
  absl::MutexLock lock(&mutex_);
  const int64_t target = recorded_;
  while (written_ < target) done_cv_.Wait(&mutex_);
}

void AuditLog::WriterLoop() {
  while (true) {
    std::vector<store::AuditRecord> batch;
    size_t taken;
    {
      absl::MutexLock lock(&mutex_);
      while (!stopping_ && queue_.empty()) work_cv_.Wait(&mutex_);
      if (queue_.empty() && stopping_) return;
      while (!queue_.empty() && batch.size() < kBatch) {
        batch.push_back(std::move(queue_.front()));
        queue_.pop_front();
      }
      taken = batch.size();
      if (dropped_ > 0) {
        store::AuditRecord note;
        note.time_ms = absl::ToUnixMillis(absl::Now());
        note.method = "(audit log)";
        note.status_code =
            static_cast<int>(absl::StatusCode::kResourceExhausted);
        note.message =
            absl::StrCat(dropped_, " audit rows were dropped: more than ",
                         kMaxQueued, " were waiting");
        batch.push_back(std::move(note));
        dropped_ = 0;
      }
    }
    if (absl::Status s = repository_.Append(batch); !s.ok()) {
      spdlog::error("audit log: cannot write {} rows: {}", batch.size(),
                    std::string(s.message()));
    }
    absl::MutexLock lock(&mutex_);
    written_ += static_cast<int64_t>(taken);
    done_cv_.SignalAll();
  }
}

}  // namespace hdrstereo::rpc
