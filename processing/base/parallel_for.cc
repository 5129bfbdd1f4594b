// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/base/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "absl/base/thread_annotations.h"
#include "absl/synchronization/mutex.h"

namespace hdrstereo {
namespace {

// The first error of the units, shared by the workers.
class FirstError {
 public:
  bool Set() const ABSL_LOCKS_EXCLUDED(mu_) {
    absl::MutexLock l(&mu_);
    return !status_.ok();
  }
  void Keep(absl::Status s) ABSL_LOCKS_EXCLUDED(mu_) {
    absl::MutexLock l(&mu_);
    if (status_.ok()) status_ = std::move(s);
  }
  absl::Status Get() const ABSL_LOCKS_EXCLUDED(mu_) {
    absl::MutexLock l(&mu_);
    return status_;
  }

 private:
  mutable absl::Mutex mu_;
  absl::Status status_ ABSL_GUARDED_BY(mu_);
};

}  // namespace

absl::Status ParallelFor(int n, int threads,
                         const std::function<absl::Status(int)>& unit) {
  std::atomic<int> next{0};
  FirstError first;
  auto work = [&] {
    while (!first.Set()) {
      const int i = next.fetch_add(1);
      if (i >= n) return;
      if (absl::Status s = unit(i); !s.ok()) first.Keep(std::move(s));
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::clamp(threads, 1, std::max(n, 1)); ++t) {
    pool.emplace_back(work);
  }
  work();
  for (std::thread& t : pool) t.join();
  return first.Get();
}

}  // namespace hdrstereo
