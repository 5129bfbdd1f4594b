// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo capture stereo|sl|calibration` and
// `hdrstereo jobs list|show|watch|pause|resume|continue|cancel`.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/time/clock.h"
#include "clients/cli/commands.h"
#include "clients/cli/exposure.h"
#include "clients/cli/output.h"
#include "clients/cli/progress_bar.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "processing/base/status_macros.h"
#include "proto/hdrstereo/v1/capture_defaults.h"

namespace hdrstereo::cli {

std::string StateName(v1::JobState state) {
  return absl::AsciiStrToLower(
      v1::JobState_Name(state).substr(std::string("JOB_STATE_").size()));
}

bool IsFinal(v1::JobState state) {
  return state == v1::JOB_STATE_SUCCEEDED || state == v1::JOB_STATE_FAILED ||
         state == v1::JOB_STATE_CANCELLED;
}

namespace {

void PrintJob(const v1::Job& job) {
  PrintFields(
      std::cout,
      {{"job", absl::StrCat(job.id())},
       {"session", job.session()},
       {"kind", job.kind() == v1::JOB_KIND_CAPTURE ? "capture" : "processing"},
       {"state", StateName(job.state())},
       {"progress",
        absl::StrCat(job.progress().done(), "/", job.progress().total(), "  ",
                     job.progress().step())},
       {"created", FormatTime(job.create_time())},
       {"submitted by", job.submitted_by().empty() ? "-" : job.submitted_by()},
       {"cluster job", job.cluster_job_id() == 0
                           ? "-"
                           : absl::StrCat("Slurm ", job.cluster_job_id())},
       {"suspended",
        job.suspension_reason().empty() ? "-" : job.suspension_reason()},
       {"waiting for",
        job.instruction().empty()
            ? "-"
            : absl::StrCat(job.instruction(), " (hdrstereo jobs continue ",
                           job.id(), ")")},
       {"error", job.error().empty() ? "-" : job.error()}});
  if (job.has_projector_timing()) {
    // "latency 0.120 s (probed; each frame waits it), refresh 60.00 Hz".
    const v1::ProjectorTiming& timing = job.projector_timing();
    PrintFields(
        std::cout,
        {{"projector",
          absl::StrCat(
              timing.has_latency_s()
                  ? absl::StrFormat("latency %.3f s (probed; each frame "
                                    "waits it)",
                                    timing.latency_s())
                  : "latency not probed",
              timing.has_refresh_hz()
                  ? absl::StrFormat(", refresh %.2f Hz", timing.refresh_hz())
                  : ", refresh rate unknown")}});
  }
  if (!job.capture().bracketed_stereo().has_auto_bracket()) return;
  const v1::AutoBracketChoice& chosen = job.auto_bracket();
  if (chosen.exposures_s().empty()) {
    std::cout << "auto bracket  not chosen yet (the scene is metered when the "
                 "capture starts)\n";
    return;
  }
  std::vector<std::string> exposures;
  for (double e : chosen.exposures_s()) exposures.push_back(FormatExposure(e));
  PrintFields(
      std::cout,
      {{"auto bracket",
        absl::StrFormat("%d exposures (the thesis' fixed bracket has %d): %s",
                        chosen.exposures_s_size(),
                        v1::kDefaultStereoExposuresS.size(),
                        absl::StrJoin(exposures, ", "))},
       {"scene range", absl::StrFormat("%.1f stops (the camera covers %.1f)",
                                       chosen.scene_range_stops(),
                                       chosen.camera_range_stops())},
       {"coverage",
        absl::StrFormat("%.2f %% of the non-emitter pixels at SNR >= %g",
                        100 * chosen.coverage(), chosen.min_snr())},
       {"emitters",
        absl::StrFormat("%d pixels (%.2f %%) excluded", chosen.emitter_pixels(),
                        100 * chosen.emitter_fraction())},
       {"sensor noise",
        absl::StrFormat("full well %.0f e-, read noise %.1f e- (%d probes)",
                        chosen.full_well_e(), chosen.read_noise_e(),
                        chosen.probes())},
       {"reason", chosen.reason()}});
}

// Ctrl-C while watching leaves the job running on the daemon.
void StopWatching(int) {
  static const char kMessage[] =
      "\nstopped watching; the job goes on (hdrstereo jobs watch ID)\n";
  ssize_t ignored = write(STDERR_FILENO, kMessage, sizeof kMessage - 1);
  (void)ignored;
  _exit(130);
}

}  // namespace

int WatchJob(const Client& client, int64_t job_id) {
  signal(SIGINT, StopWatching);
  const bool tty = isatty(STDOUT_FILENO);
  // A stream cut by the network (or a restart of the daemon) is resumed
  // after the last event received (after_sequence), with backoff, until the
  // daemon has been out of reach for kGiveUp.
  constexpr absl::Duration kFirstRetry = absl::Milliseconds(200);
  constexpr absl::Duration kMaxRetry = absl::Seconds(5);
  constexpr absl::Duration kGiveUp = absl::Minutes(5);
  absl::Duration retry = kFirstRetry;
  absl::Time last_contact = absl::Now();
  int64_t last_sequence = 0;
  v1::JobState last_state = v1::JOB_STATE_UNSPECIFIED;
  absl::Time rate_start = absl::InfinitePast();
  int64_t rate_done = 0;
  bool bar_open = false;
  while (true) {
    std::unique_ptr<grpc::ClientContext> context = client.NewStreamContext();
    v1::WatchJobRequest request;
    request.set_job_id(job_id);
    request.set_after_sequence(last_sequence);
    auto reader =
        v1::Jobs::NewStub(client.channel())->Watch(context.get(), request);
    v1::JobEvent event;
    while (reader->Read(&event)) {
      last_contact = absl::Now();
      retry = kFirstRetry;
      last_sequence = event.sequence();
      const absl::Time t = absl::FromUnixSeconds(event.time().seconds()) +
                           absl::Nanoseconds(event.time().nanos());
      const int64_t done = event.progress().done();
      const int64_t total = event.progress().total();
      if (client.options().json) {
        PrintJson(std::cout, event);
        std::cout << std::flush;
      } else if (tty && event.message().empty() && total > 0) {
        if (rate_start == absl::InfinitePast() ||
            event.state() != v1::JOB_STATE_RUNNING) {
          rate_start = t;
          rate_done = done;
        }
        const double elapsed = absl::ToDoubleSeconds(t - rate_start);
        const double rate = elapsed > 0 ? (done - rate_done) / elapsed : 0;
        std::cout << "\r"
                  << ProgressLine(done, total, rate, event.progress().step())
                  << std::flush;
        bar_open = true;
      } else if (!event.message().empty() || event.state() != last_state ||
                 !tty) {
        if (bar_open) std::cout << "\n";
        bar_open = false;
        std::cout << absl::StrFormat(
            "%s job %d %s %d/%d %s%s%s\n", FormatTime(event.time()), job_id,
            StateName(event.state()), done, total, event.progress().step(),
            event.message().empty() ? "" : "  ", event.message());
      }
      last_state = event.state();
    }
    grpc::Status status = reader->Finish();
    if (status.ok()) break;
    // Only a stream that worked is resumed: a daemon that cannot be reached
    // at all is reported at once.
    if (status.error_code() != grpc::StatusCode::UNAVAILABLE ||
        last_sequence == 0 || absl::Now() - last_contact > kGiveUp) {
      if (bar_open) std::cout << "\n";
      return client.Fail(status);
    }
    if (bar_open) std::cout << "\n";
    bar_open = false;
    std::cerr << "hdrstereo: lost the stream of job " << job_id << " ("
              << status.error_message() << "); resuming after event "
              << last_sequence << " in " << absl::FormatDuration(retry) << "\n";
    absl::SleepFor(retry);
    retry = std::min(retry * 2, kMaxRetry);
  }
  if (bar_open) std::cout << "\n";
  if (!IsFinal(last_state)) return kExitError;
  return last_state == v1::JOB_STATE_SUCCEEDED ? kExitOk : kExitError;
}

namespace {

int Submit(const Client& client, const v1::SubmitCaptureRequest& request,
           bool watch) {
  v1::Job job;
  grpc::Status status =
      v1::Jobs::NewStub(client.channel())
          ->SubmitCapture(client.NewContext().get(), request, &job);
  if (!status.ok()) return client.Fail(status);
  if (client.options().json) {
    PrintJson(std::cout, job);
  } else if (request.plan().bracketed_stereo().has_auto_bracket()) {
    std::cout << "job " << job.id() << " queued in session " << job.session()
              << ": its exposures are chosen by metering the scene first\n";
  } else {
    std::cout << "job " << job.id() << " queued: " << job.progress().total()
              << " frames in session " << job.session() << "\n";
  }
  return watch ? WatchJob(client, job.id()) : kExitOk;
}

// "1/30,1/125": the daemon's default exposures as --exposures takes them.
template <size_t N>
std::string Defaults(const std::array<double, N>& exposures) {
  std::vector<std::string> out;
  for (double e : exposures) out.push_back(absl::StrFormat("1/%.0f", 1 / e));
  return absl::StrJoin(out, ",");
}

}  // namespace

void AddJobCommands(CLI::App& app, const GlobalOptions& options,
                    int* exit_code) {
  struct Args {
    std::string session;
    std::string exposures;
    double baseline_mm = 0;
    int views = 0;
    int iso = 0;
    int poses = 0;
    std::string board;
    double board_square_mm = 0;
    bool no_ambient = false;
    bool auto_bracket = false;
    double min_snr = 0;
    double max_step = 0;
    double exclude_emitters_above = 0;
    double max_uncovered = 0;
    std::string max_exposure;
    bool probe_projector = false;
    bool round_to_refresh = false;
    bool watch = false;
    int64_t job_id = 0;
    std::string filter_session;
  };
  auto args = std::make_shared<Args>();
  auto exposures = [args](google::protobuf::RepeatedField<double>* out) {
    if (args->exposures.empty()) return absl::OkStatus();
    ASSIGN_OR_RETURN(std::vector<double> list,
                     ParseExposureList(args->exposures));
    for (double e : list) out->Add(e);
    return absl::OkStatus();
  };

  CLI::App* capture = app.add_subcommand("capture", "Start a capture job");
  capture->require_subcommand(1);
  auto common = [&](CLI::App* sub) {
    sub->add_option("SESSION", args->session, "Session to capture into")
        ->required();
    sub->add_flag("--watch", args->watch, "Follow the job's progress");
  };

  CLI::App* stereo = capture->add_subcommand(
      "stereo", "Bracketed stereo: every exposure at each view");
  common(stereo);
  stereo->add_option("--exposures", args->exposures,
                     absl::StrCat("Comma-separated, e.g. 1/15,1/30 [default: ",
                                  Defaults(v1::kDefaultStereoExposuresS), "]"));
  stereo->add_option("--baseline-mm", args->baseline_mm,
                     absl::StrCat("Distance between views [default: ",
                                  v1::kDefaultBaselineMm, "]"));
  stereo->add_option(
      "--views", args->views,
      absl::StrCat("Number of views [default: ", v1::kDefaultViews, "]"));
  stereo->add_option("--iso", args->iso, "ISO [default: camera's]");
  stereo->add_flag("--no-ambient", args->no_ambient,
                   "Skip the ambient frame taken first");
  CLI::Option* auto_flag = stereo->add_flag(
      "--auto", args->auto_bracket,
      "Choose the exposures at the rig: meter each view with probe frames "
      "and take the fewest shutter speeds that give every pixel a "
      "well-exposed sample");
  auto_flag->excludes(stereo->get_option("--exposures"));
  stereo
      ->add_option("--min-snr", args->min_snr,
                   "--auto: per-sample SNR, 10 .. 1000 [default: 40, ISO "
                   "12232 \"excellent\"]")
      ->needs(auto_flag);
  stereo
      ->add_option("--max-step", args->max_step,
                   "--auto: most stops between neighbouring exposures "
                   "[default: 2/3 (the camera's own format, 8-bit); 1 for "
                   "plans that ask for 16-bit TIFF or RAW]")
      ->needs(auto_flag);
  stereo
      ->add_option("--exclude-emitters-above", args->exclude_emitters_above,
                   "--auto: pixels brighter than this many times their "
                   "view's median are emitters, excluded and reported "
                   "[default: none excluded]")
      ->needs(auto_flag);
  stereo
      ->add_option("--max-uncovered", args->max_uncovered,
                   "--auto: fraction of the other pixels that may stay "
                   "uncovered [default: 0]")
      ->needs(auto_flag);
  stereo
      ->add_option("--max-exposure", args->max_exposure,
                   "--auto: longest exposure, e.g. 1/4 [default: the "
                   "camera's longest]")
      ->needs(auto_flag);
  stereo->callback([&options, exit_code, args, exposures] {
    Client client(options);
    v1::SubmitCaptureRequest request;
    request.set_session(args->session);
    v1::BracketedStereoPlan* plan =
        request.mutable_plan()->mutable_bracketed_stereo();
    if (absl::Status s = exposures(plan->mutable_exposures_s()); !s.ok()) {
      std::cerr << "hdrstereo: " << s.message() << "\n";
      *exit_code = kExitUsage;
      return;
    }
    plan->set_baseline_mm(args->baseline_mm);
    plan->set_views(args->views);
    plan->set_iso(args->iso);
    plan->set_skip_ambient(args->no_ambient);
    if (args->auto_bracket) {
      v1::AutoBracket* a = plan->mutable_auto_bracket();
      a->set_min_snr(args->min_snr);
      a->set_max_step_stops(args->max_step);
      a->set_exclude_emitters_above(args->exclude_emitters_above);
      a->set_max_uncovered_fraction(args->max_uncovered);
      if (!args->max_exposure.empty()) {
        absl::StatusOr<double> longest = ParseExposure(args->max_exposure);
        if (!longest.ok()) {
          std::cerr << "hdrstereo: --max-exposure: "
                    << longest.status().message() << "\n";
          *exit_code = kExitUsage;
          return;
        }
        a->set_max_exposure_s(*longest);
      }
    }
    *exit_code = Submit(client, request, args->watch);
  });

  CLI::App* sl = capture->add_subcommand(
      "sl", "Structured light: Gray codes at each exposure and view");
  common(sl);
  sl->add_option(
      "--exposures", args->exposures,
      absl::StrCat("Comma-separated [default: ",
                   Defaults(v1::kDefaultStructuredLightExposuresS), "]"));
  sl->add_option("--baseline-mm", args->baseline_mm,
                 absl::StrCat("[default: ", v1::kDefaultBaselineMm, "]"));
  sl->add_option("--views", args->views,
                 absl::StrCat("[default: ", v1::kDefaultViews, "]"));
  sl->add_flag("--probe-projector", args->probe_projector,
               "Measure the projector's latency first (as `hw projector "
               "probe`) and wait that long after each pattern");
  sl->add_flag("--round-to-refresh", args->round_to_refresh,
               "Round each exposure to whole refresh periods of the "
               "projector's display");
  sl->callback([&options, exit_code, args, exposures] {
    Client client(options);
    v1::SubmitCaptureRequest request;
    request.set_session(args->session);
    v1::StructuredLightPlan* plan =
        request.mutable_plan()->mutable_structured_light();
    if (absl::Status s = exposures(plan->mutable_exposures_s()); !s.ok()) {
      std::cerr << "hdrstereo: " << s.message() << "\n";
      *exit_code = kExitUsage;
      return;
    }
    plan->set_baseline_mm(args->baseline_mm);
    plan->set_views(args->views);
    if (args->probe_projector) plan->mutable_projector_probe();
    plan->set_round_exposures_to_refresh(args->round_to_refresh);
    *exit_code = Submit(client, request, args->watch);
  });

  CLI::App* calibration =
      capture->add_subcommand("calibration", "Checkerboard poses, both views");
  common(calibration);
  calibration->add_option("--poses", args->poses, "Number of poses")
      ->required();
  calibration->add_option(
      "--board", args->board,
      absl::StrCat("Inner corners of the chessboard, COLUMNSxROWS [default: ",
                   v1::kDefaultBoardColumns, "x", v1::kDefaultBoardRows, "]"));
  calibration->add_option(
      "--board-square-mm", args->board_square_mm,
      absl::StrCat("Edge of one square; sets the scale of the calibrated "
                   "baseline [default: ",
                   v1::kDefaultBoardSquareMm, "]"));
  calibration->callback([&options, exit_code, args] {
    v1::SubmitCaptureRequest request;
    request.set_session(args->session);
    v1::CalibrationPlan* plan = request.mutable_plan()->mutable_calibration();
    plan->set_poses(args->poses);
    if (!args->board.empty()) {
      const std::vector<std::string> sides =
          absl::StrSplit(absl::AsciiStrToLower(args->board), 'x');
      int columns = 0, rows = 0;
      if (sides.size() != 2 || !absl::SimpleAtoi(sides[0], &columns) ||
          !absl::SimpleAtoi(sides[1], &rows)) {
        std::cerr << "hdrstereo: --board \"" << args->board
                  << "\" is not COLUMNSxROWS, e.g. 9x6\n";
        *exit_code = kExitUsage;
        return;
      }
      plan->set_board_columns(columns);
      plan->set_board_rows(rows);
    }
    plan->set_board_square_mm(args->board_square_mm);
    Client client(options);
    *exit_code = Submit(client, request, args->watch);
  });

  CLI::App* jobs = app.add_subcommand("jobs", "List, follow and steer jobs");
  jobs->require_subcommand(1);
  CLI::App* list = jobs->add_subcommand("list", "List jobs");
  list->add_option("--session", args->filter_session, "Only this session");
  list->callback([&options, exit_code, args] {
    Client client(options);
    auto stub = v1::Jobs::NewStub(client.channel());
    v1::ListJobsRequest request;
    request.set_session(args->filter_session);
    v1::ListJobsResponse all;
    do {
      v1::ListJobsResponse page;
      grpc::Status status =
          stub->List(client.NewContext().get(), request, &page);
      if (!status.ok()) {
        *exit_code = client.Fail(status);
        return;
      }
      all.mutable_jobs()->MergeFrom(page.jobs());
      request.mutable_page()->set_page_token(page.next_page_token());
    } while (!request.page().page_token().empty());
    *exit_code = Finish(
        client, grpc::Status::OK, all, [](const v1::ListJobsResponse& r) {
          if (r.jobs().empty()) {
            std::cout << "no jobs\n";
            return;
          }
          // REASON: why it failed, or why a condition suspends it.
          Table table({"ID", "SESSION", "KIND", "STATE", "PROGRESS", "CREATED",
                       "BY", "REASON"});
          for (const v1::Job& j : r.jobs()) {
            table.AddRow(
                {absl::StrCat(j.id()), j.session(),
                 j.kind() == v1::JOB_KIND_CAPTURE ? "capture" : "processing",
                 StateName(j.state()),
                 absl::StrCat(j.progress().done(), "/", j.progress().total()),
                 FormatTime(j.create_time()),
                 j.submitted_by().empty() ? "-" : j.submitted_by(),
                 !j.instruction().empty()
                     ? absl::StrCat("waiting: ", j.instruction())
                 : j.suspension_reason().empty()
                     ? j.error()
                     : absl::StrCat("suspended: ", j.suspension_reason())});
          }
          table.Print(std::cout);
        });
  });

  auto job_command = [&](const std::string& name, const std::string& help,
                         auto call) {
    CLI::App* sub = jobs->add_subcommand(name, help);
    sub->add_option("ID", args->job_id, "Job id")->required();
    sub->callback([&options, exit_code, args, call] {
      Client client(options);
      *exit_code = call(client, args->job_id);
    });
  };
  job_command("show", "Show one job", [](const Client& client, int64_t id) {
    v1::GetJobRequest request;
    request.set_job_id(id);
    v1::Job job;
    grpc::Status status = v1::Jobs::NewStub(client.channel())
                              ->Get(client.NewContext().get(), request, &job);
    return Finish(client, status, job, PrintJob);
  });
  job_command(
      "watch", "Follow a job until it ends (Ctrl-C stops watching)",
      [](const Client& client, int64_t id) { return WatchJob(client, id); });
  job_command("pause", "Pause after the current frame",
              [](const Client& client, int64_t id) {
                v1::PauseJobRequest request;
                request.set_job_id(id);
                v1::Job job;
                grpc::Status status =
                    v1::Jobs::NewStub(client.channel())
                        ->Pause(client.NewContext().get(), request, &job);
                return Finish(client, status, job, PrintJob);
              });
  job_command("resume", "Resume a paused job",
              [](const Client& client, int64_t id) {
                v1::ResumeJobRequest request;
                request.set_job_id(id);
                v1::Job job;
                grpc::Status status =
                    v1::Jobs::NewStub(client.channel())
                        ->Resume(client.NewContext().get(), request, &job);
                return Finish(client, status, job, PrintJob);
              });
  job_command("continue",
              "Let a waiting job go on (e.g. the calibration board is placed)",
              [](const Client& client, int64_t id) {
                v1::ContinueJobRequest request;
                request.set_job_id(id);
                v1::Job job;
                grpc::Status status =
                    v1::Jobs::NewStub(client.channel())
                        ->Continue(client.NewContext().get(), request, &job);
                return Finish(client, status, job, PrintJob);
              });
  job_command("cancel", "Cancel a job (hardware is left safe)",
              [](const Client& client, int64_t id) {
                v1::CancelJobRequest request;
                request.set_job_id(id);
                v1::Job job;
                grpc::Status status =
                    v1::Jobs::NewStub(client.channel())
                        ->Cancel(client.NewContext().get(), request, &job);
                return Finish(client, status, job, PrintJob);
              });
}

}  // namespace hdrstereo::cli
