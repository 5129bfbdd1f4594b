// SPDX-License-Identifier: GPL-3.0-or-later
//
// What processing jobs produced: artifact rows (one per file under the
// session folder, with the pipeline step that wrote it and the hash of that
// step's inputs) and metrics rows (one per method and ground truth).
#ifndef HDRSTEREO_DAEMON_STORE_ARTIFACT_REPOSITORY_H_
#define HDRSTEREO_DAEMON_STORE_ARTIFACT_REPOSITORY_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "daemon/store/store.h"

namespace hdrstereo::store {

struct ArtifactRecord {
  int64_t id = 0;
  int64_t job_id = 0;  // 0 when the job was deleted
  std::string step;
  std::string kind;
  std::string path;  // relative to the session folder
  std::string params_json;
  std::string params_hash;
  std::string sha256;
  int64_t size_bytes = 0;
  int64_t create_time_ms = 0;
};

struct MetricRecord {
  std::string method;
  std::string ground_truth;
  double rmse = 0;
  double mae = 0;
  double bad_0_5 = 0;
  double bad_1 = 0;
  double bad_2 = 0;
  double bad_4 = 0;
  double coverage = 0;
  int64_t job_id = 0;
};

class ArtifactRepository {
 public:
  explicit ArtifactRepository(Store& store) : store_(store) {}

  // Artifacts of `step` recorded with `params_hash`; empty if none.
  absl::StatusOr<std::vector<ArtifactRecord>> ForStep(
      int64_t session_id, absl::string_view step,
      absl::string_view params_hash);

  // Replaces, in one transaction, the session's artifacts of `step` (and
  // any other row for the same paths) with `artifacts`.
  absl::Status ReplaceStep(int64_t session_id, int64_t job_id,
                           absl::string_view step,
                           const std::vector<ArtifactRecord>& artifacts);

  // Artifacts of a session ordered by id, after `after_id`, at most `limit`;
  // `kind` empty = all. NOT_FOUND for an unknown session.
  absl::StatusOr<std::vector<ArtifactRecord>> List(absl::string_view session,
                                                   absl::string_view kind,
                                                   int64_t after_id, int limit);

  // NOT_FOUND naming the session or the artifact.
  absl::StatusOr<ArtifactRecord> Get(absl::string_view session,
                                     int64_t artifact_id);

  // Replaces the session's metrics rows in one transaction.
  absl::Status ReplaceMetrics(int64_t session_id, int64_t job_id,
                              const std::vector<MetricRecord>& metrics);
  // Ordered by ground truth, then RMSE.
  absl::StatusOr<std::vector<MetricRecord>> Metrics(int64_t session_id);

 private:
  Store& store_;
};

}  // namespace hdrstereo::store

#endif  // HDRSTEREO_DAEMON_STORE_ARTIFACT_REPOSITORY_H_
