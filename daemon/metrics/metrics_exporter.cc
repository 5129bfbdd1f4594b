// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/metrics/metrics_exporter.h"

#include <prometheus/collectable.h>
#include <prometheus/exposer.h>
#include <prometheus/metric_family.h>
#include <spdlog/spdlog.h>

#include <exception>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/types/span.h"
#include "daemon/store/event_kind.h"
#include "daemon/store/metrics_repository.h"
#include "processing/pipeline/pipeline.h"

namespace hdrstereo::metrics {

namespace {

// Upper bounds of the histograms' buckets, in seconds: a capture's frames
// and device calls (a 30 s exposure included), and processing steps.
constexpr double kCaptureSecondsBuckets[] = {0.1, 0.25, 0.5, 1, 2,
                                             5,   10,   30,  60};
constexpr double kStepSecondsBuckets[] = {0.1, 0.5, 1,   5,   10,
                                          30,  60,  300, 900, 3600};

prometheus::MetricFamily Family(std::string name, std::string help,
                                prometheus::MetricType type) {
  prometheus::MetricFamily family;
  family.name = std::move(name);
  family.help = std::move(help);
  family.type = type;
  return family;
}

prometheus::ClientMetric Value(prometheus::MetricType type, double value) {
  prometheus::ClientMetric metric;
  if (type == prometheus::MetricType::Counter) {
    metric.counter.value = value;
  } else {
    metric.gauge.value = value;
  }
  return metric;
}

prometheus::MetricFamily Single(std::string name, std::string help,
                                prometheus::MetricType type, double value) {
  prometheus::MetricFamily family =
      Family(std::move(name), std::move(help), type);
  family.metric.push_back(Value(type, value));
  return family;
}

prometheus::ClientMetric Histogram(const std::vector<double>& samples,
                                   absl::Span<const double> bounds) {
  prometheus::ClientMetric metric;
  for (double bound : bounds) {
    prometheus::ClientMetric::Bucket bucket;
    bucket.upper_bound = bound;
    metric.histogram.bucket.push_back(bucket);
  }
  prometheus::ClientMetric::Bucket inf;
  inf.upper_bound = std::numeric_limits<double>::infinity();
  metric.histogram.bucket.push_back(inf);
  for (double s : samples) {
    metric.histogram.sample_sum += s;
    for (prometheus::ClientMetric::Bucket& bucket : metric.histogram.bucket) {
      if (s <= bucket.upper_bound) ++bucket.cumulative_count;
    }
  }
  metric.histogram.sample_count = samples.size();
  return metric;
}

prometheus::ClientMetric Labelled(
    prometheus::ClientMetric metric,
    std::vector<prometheus::ClientMetric::Label> labels) {
  metric.label = std::move(labels);
  return metric;
}

// Counts of the event kinds of `family`, one series per kind; device errors
// are labelled by device and kind.
prometheus::MetricFamily EventCounts(const store::StoreTotals& totals,
                                     store::EventFamily family,
                                     std::string name, std::string help) {
  prometheus::MetricFamily out =
      Family(std::move(name), std::move(help), prometheus::MetricType::Counter);
  for (store::EventKind kind : store::KindsOf(family)) {
    std::vector<prometheus::ClientMetric::Label> labels;
    if (const std::optional<store::Device> device = store::DeviceOf(kind)) {
      labels.push_back({"device", store::DeviceName(*device)});
    }
    labels.push_back({"kind", store::LabelOf(kind)});
    const auto count = totals.events_by_kind.find(kind);
    out.metric.push_back(
        Labelled(Value(prometheus::MetricType::Counter,
                       count == totals.events_by_kind.end()
                           ? 0
                           : static_cast<double>(count->second)),
                 std::move(labels)));
  }
  return out;
}

}  // namespace

// Reads the store at every scrape (on the exposer's threads).
class StoreCollector : public prometheus::Collectable {
 public:
  StoreCollector(store::Store& store, const jobs::DiskGuard& disk_guard)
      : store_(store), disk_guard_(disk_guard) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    using prometheus::MetricType;
    std::vector<prometheus::MetricFamily> out;
    absl::StatusOr<store::StoreTotals> totals =
        store::MetricsRepository(store_).Read();
    out.push_back(Single("hdrstereo_metrics_store_read_ok",
                         "1 when the store could be read for this scrape",
                         MetricType::Gauge, totals.ok() ? 1 : 0));
    if (totals.ok()) {
      prometheus::MetricFamily jobs = Family(
          "hdrstereo_jobs", "Jobs in the store by state", MetricType::Gauge);
      for (const auto& [state, count] : totals->jobs_by_state) {
        prometheus::ClientMetric metric =
            Value(MetricType::Gauge, static_cast<double>(count));
        metric.label.push_back({"state", state});
        jobs.metric.push_back(std::move(metric));
      }
      out.push_back(std::move(jobs));
      out.push_back(Single("hdrstereo_frames_captured_total",
                           "Frames recorded in the store", MetricType::Counter,
                           static_cast<double>(totals->frames)));
      out.push_back(Single("hdrstereo_frames_verified_total",
                           "Frames recorded with camera-reported values",
                           MetricType::Counter,
                           static_cast<double>(totals->frames_verified)));
      out.push_back(Single(
          "hdrstereo_suspensions_total", "Job events that suspended a job",
          MetricType::Counter, static_cast<double>(totals->suspensions)));
      prometheus::MetricFamily frame_time =
          Family("hdrstereo_capture_frame_seconds",
                 "Time between consecutive frames of a capture job",
                 MetricType::Histogram);
      frame_time.metric.push_back(
          Histogram(totals->frame_seconds, kCaptureSecondsBuckets));
      out.push_back(std::move(frame_time));
      out.push_back(EventCounts(
          *totals, store::EventFamily::kVerificationFailure,
          "hdrstereo_frame_verification_failures_total",
          "Frames rejected by their check against the camera, by kind"));
      out.push_back(EventCounts(*totals, store::EventFamily::kDeviceError,
                                "hdrstereo_device_errors_total",
                                "Failed device calls of capture jobs"));
      prometheus::MetricFamily device_time = Family(
          "hdrstereo_device_seconds",
          "Time of each capture, stage move and projector pattern of capture "
          "jobs",
          MetricType::Histogram);
      for (const auto& [device, seconds] : totals->device_seconds) {
        device_time.metric.push_back(
            Labelled(Histogram(seconds, kCaptureSecondsBuckets),
                     {{"device", store::DeviceName(device)}}));
      }
      out.push_back(std::move(device_time));
      prometheus::MetricFamily steps = Family(
          "hdrstereo_processing_step_seconds",
          "Time of each computed processing step", MetricType::Histogram);
      for (const std::string& step : pipeline::AllSteps()) {
        const auto seconds = totals->step_seconds.find(step);
        steps.metric.push_back(
            Labelled(Histogram(seconds == totals->step_seconds.end()
                                   ? std::vector<double>()
                                   : seconds->second,
                               kStepSecondsBuckets),
                     {{"step", step}}));
      }
      out.push_back(std::move(steps));
    } else {
      spdlog::warn("metrics: reading the store failed: {}",
                   totals.status().ToString());
    }
    if (absl::StatusOr<int64_t> free = disk_guard_.FreeBytes(); free.ok()) {
      out.push_back(Single("hdrstereo_data_root_free_bytes",
                           "Free bytes on the data root's filesystem",
                           MetricType::Gauge, static_cast<double>(*free)));
    }
    return out;
  }

 private:
  store::Store& store_;
  const jobs::DiskGuard& disk_guard_;
};

absl::StatusOr<std::unique_ptr<MetricsExporter>> MetricsExporter::Start(
    const std::string& address, store::Store& store,
    const jobs::DiskGuard& disk_guard) {
  std::unique_ptr<prometheus::Exposer> exposer;
  try {
    // One thread: scrapes are rare and each takes the database lock anyway.
    exposer = std::make_unique<prometheus::Exposer>(address, 1);
  } catch (const std::exception& e) {
    return absl::UnavailableError(
        absl::StrCat("--metrics-listen \"", address,
                     "\" cannot be served (port taken?): ", e.what()));
  }
  std::vector<int> ports = exposer->GetListeningPorts();
  if (ports.empty()) {
    return absl::UnavailableError(
        absl::StrCat("--metrics-listen \"", address, "\" bound no port"));
  }
  auto collector = std::make_shared<StoreCollector>(store, disk_guard);
  exposer->RegisterCollectable(collector);
  return std::unique_ptr<MetricsExporter>(
      new MetricsExporter(std::move(exposer), std::move(collector), ports[0]));
}

MetricsExporter::MetricsExporter(std::unique_ptr<prometheus::Exposer> exposer,
                                 std::shared_ptr<StoreCollector> collector,
                                 int port)
    : collector_(std::move(collector)),
      exposer_(std::move(exposer)),
      port_(port) {}

MetricsExporter::~MetricsExporter() = default;

}  // namespace hdrstereo::metrics
