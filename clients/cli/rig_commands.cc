// SPDX-License-Identifier: GPL-3.0-or-later
//
// At the rig: `hdrstereo hw preview` (live view with exposure statistics)
// and `hdrstereo hw projector probe` (the projector's latency and refresh
// rate).
#include <signal.h>

#include <atomic>
#include <iostream>
#include <memory>
#include <thread>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "clients/cli/commands.h"
#include "clients/cli/exposure.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"
#include "processing/io/atomic_file.h"

namespace hdrstereo::cli {
namespace {

std::atomic<bool> interrupted{false};

void OnInterrupt(int) { interrupted = true; }

// While it lives, Ctrl-C cancels `context` (from a thread of its own: a
// signal handler may not call into gRPC).
class CancelOnInterrupt {
 public:
  explicit CancelOnInterrupt(grpc::ClientContext* context) {
    interrupted = false;
    signal(SIGINT, OnInterrupt);
    watcher_ = std::thread([this, context] {
      while (!done_) {
        if (interrupted) {
          context->TryCancel();
          return;
        }
        absl::SleepFor(absl::Milliseconds(50));
      }
    });
  }
  ~CancelOnInterrupt() {
    done_ = true;
    watcher_.join();
    signal(SIGINT, SIG_DFL);
  }
  CancelOnInterrupt(const CancelOnInterrupt&) = delete;
  CancelOnInterrupt& operator=(const CancelOnInterrupt&) = delete;

  bool interrupted_now() const { return interrupted; }

 private:
  std::atomic<bool> done_{false};
  std::thread watcher_;
};

// One line per frame: "#3 480x360 1/125 s  red p1/50/99 4/97/255 clipped
// 0.0%/2.1%  green ...".
std::string StatisticsLine(const v1::PreviewFrame& frame) {
  std::string line =
      absl::StrFormat("#%d %dx%d %s", frame.sequence(), frame.width_px(),
                      frame.height_px(), FormatExposure(frame.exposure_s()));
  for (const v1::ChannelStatistics& c : frame.channels()) {
    absl::StrAppendFormat(&line, "  %s p1/50/99 %d/%d/%d clipped %.1f%%/%.1f%%",
                          c.channel(), c.p1(), c.p50(), c.p99(),
                          100 * c.clipped_low(), 100 * c.clipped_high());
  }
  if (frame.has_calibration()) {
    // "  calibration job 4, pose 2 of 8: board found; 1 pose kept covers
    // 21.3% of the left view, 20.9% of the right; with this pose 38.0%".
    const v1::CalibrationGuide& g = frame.calibration();
    absl::StrAppendFormat(
        &line,
        "  calibration job %d, pose %d of %d: %s; %d pose%s kept cover%s "
        "%.1f%% of the left view, %.1f%% of the right",
        g.job_id(), g.pose(), g.poses(),
        g.board_found() ? "board found" : g.board_missing(), g.poses_kept(),
        g.poses_kept() == 1 ? "" : "s", g.poses_kept() == 1 ? "s" : "",
        100 * g.coverage_left(), 100 * g.coverage_right());
    if (g.board_found()) {
      absl::StrAppendFormat(&line, "; with this pose %.1f%%",
                            100 * g.coverage_with_this_pose());
    }
  }
  return line;
}

struct PreviewArgs {
  std::string out;
  bool watch = false;
  double fps = 0;
};

int RunPreview(const Client& client, const PreviewArgs& args) {
  if (args.fps < 0) {
    std::cerr << "hdrstereo: --fps must be positive\n";
    return kExitUsage;
  }
  v1::StreamPreviewRequest request;
  request.set_max_fps(args.fps);
  request.set_max_frames(args.watch ? 0 : 1);
  std::unique_ptr<grpc::ClientContext> context = client.NewStreamContext();
  CancelOnInterrupt cancel(context.get());
  auto reader = v1::Hardware::NewStub(client.channel())
                    ->StreamPreview(context.get(), request);
  v1::PreviewMessage message;
  int exit_code = kExitOk;
  while (exit_code == kExitOk && reader->Read(&message)) {
    if (message.has_ended()) {
      // A capture that starts ends live view: say so (the stream is fine).
      if (message.ended().capture_job_id() != 0) {
        std::cerr << "hdrstereo: live view ended: " << message.ended().reason()
                  << "\n";
      }
      continue;
    }
    v1::PreviewFrame& frame = *message.mutable_frame();
    if (!args.out.empty()) {
      if (absl::Status s = io::WriteFileAtomically(args.out, frame.jpeg());
          !s.ok()) {
        std::cerr << "hdrstereo: " << s.message() << "\n";
        context->TryCancel();
        exit_code = kExitError;
        continue;
      }
    }
    if (client.options().json) {
      frame.clear_jpeg();
      PrintJson(std::cout, frame);
    } else {
      std::cout << StatisticsLine(frame) << "\n";
    }
    std::cout << std::flush;
  }
  const grpc::Status status = reader->Finish();
  if (exit_code != kExitOk) return exit_code;
  if (cancel.interrupted_now()) {
    std::cerr << "stopped live view\n";
    return 130;
  }
  if (!status.ok()) return client.Fail(status);
  return kExitOk;
}

struct ProbeArgs {
  double step_s = 0;
  double max_delay_s = 0;
  std::string exposure;
};

void PrintProbe(const v1::ProjectorProbe& probe) {
  PrintFields(
      std::cout,
      {{"latency",
        probe.latency_s() > 0
            ? absl::StrFormat("%.3f s (the first white frame; the latency "
                              "is above %.3f s)",
                              probe.latency_s(),
                              probe.latency_s() - probe.step_s())
            : "0 s (white at once: the projector's settle time covers "
              "it)"},
       {"refresh",
        probe.refresh_hz() > 0
            ? absl::StrFormat("%.2f Hz (period %.2f ms)", probe.refresh_hz(),
                              1000 / probe.refresh_hz())
            : absl::StrCat("unknown: ", probe.refresh_error())},
       {"levels", absl::StrFormat("black %.1f, white %.1f (white from %.1f)",
                                  probe.black_level(), probe.white_level(),
                                  probe.white_from())}});
  Table table({"DELAY", "LEVEL", "SEES"});
  for (const v1::ProjectorProbe::Frame& frame : probe.frames()) {
    table.AddRow({absl::StrFormat("%.3f s", frame.delay_s()),
                  absl::StrFormat("%.1f", frame.level()),
                  frame.white() ? "white" : "black"});
  }
  table.Print(std::cout);
}

int RunProbe(const Client& client, const ProbeArgs& args) {
  v1::ProbeProjectorRequest request;
  v1::ProjectorProbeOptions* options = request.mutable_options();
  options->set_step_s(args.step_s);
  options->set_max_delay_s(args.max_delay_s);
  if (!args.exposure.empty()) {
    absl::StatusOr<double> exposure = ParseExposure(args.exposure);
    if (!exposure.ok()) {
      std::cerr << "hdrstereo: --exposure: " << exposure.status().message()
                << "\n";
      return kExitUsage;
    }
    options->set_exposure_s(*exposure);
  }
  // It takes as long as its frames do: no --timeout.
  std::unique_ptr<grpc::ClientContext> context = client.NewStreamContext();
  v1::ProjectorProbe probe;
  const grpc::Status rpc = v1::Hardware::NewStub(client.channel())
                               ->ProbeProjector(context.get(), request, &probe);
  return Finish(client, rpc, probe, PrintProbe);
}

}  // namespace

void AddRigCommands(CLI::App& hw, CLI::App& projector,
                    const GlobalOptions& options, int* exit_code) {
  auto preview_args = std::make_shared<PreviewArgs>();
  CLI::App* preview = hw.add_subcommand(
      "preview",
      "Live view: a frame with its exposure statistics (per channel "
      "1st/50th/99th percentile, clipped fractions)");
  preview->add_option("--out", preview_args->out,
                      "Write the frame (JPEG) here, replaced atomically at "
                      "each frame");
  preview->add_flag("--watch", preview_args->watch,
                    "Keep streaming (Ctrl-C stops; a capture that starts "
                    "ends it)");
  preview->add_option("--fps", preview_args->fps,
                      "Frames per second at most [default: 5; the daemon "
                      "sends at most 10]");
  preview->callback([&options, exit_code, preview_args] {
    *exit_code = RunPreview(Client(options), *preview_args);
  });

  auto probe_args = std::make_shared<ProbeArgs>();
  CLI::App* probe = projector.add_subcommand(
      "probe",
      "Measure the projector's latency (black, then white, frames at "
      "increasing delays) and read the display's refresh rate");
  probe->add_option("--step", probe_args->step_s,
                    "Delay step in seconds [default: 0.02]");
  probe->add_option("--max-delay", probe_args->max_delay_s,
                    "Longest delay tried, in seconds [default: 0.5]");
  probe->add_option("--exposure", probe_args->exposure,
                    "Exposure of the probe frames, e.g. 1/125 [default]");
  probe->callback([&options, exit_code, probe_args] {
    *exit_code = RunProbe(Client(options), *probe_args);
  });
}

}  // namespace hdrstereo::cli
