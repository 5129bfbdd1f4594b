// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo process|metrics|artifacts|download|report`: start a session's
// processing, read its evaluation, list and fetch what it produced.
#include <openssl/evp.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "clients/cli/commands.h"
#include "clients/cli/output.h"
#include "hdrstereo/v1/jobs.grpc.pb.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

namespace fs = std::filesystem;

// What a user needs before the table: how good the structured-light
// ground truth is (when the simulator's exact truth can score it), then per
// ground truth the best methods and, in words, any method worse than LDR.
void PrintMetricsHeadline(const v1::ListMetricsResponse& r) {
  constexpr char kGroundTruthMethod[] = "structured_light";
  for (const v1::Metric& m : r.metrics()) {
    if (m.method() != kGroundTruthMethod) continue;
    // Bad counts a pixel without a disparity as bad at every threshold
    // (processing/eval); of the covered ones, this share is off by > 1 px.
    const double off =
        m.coverage() > 0
            ? 100.0 * (m.bad_1() - (100.0 - m.coverage())) / m.coverage()
            : 0.0;
    std::cout << absl::StrFormat(
        "structured-light ground truth, against the simulator's exact truth: "
        "covers %.1f%% of the non-occluded pixels; where it has a disparity, "
        "RMSE %.3f px and %.1f%% off by more than 1 px\n",
        m.coverage(), m.rmse_px(), std::max(0.0, off));
  }
  std::vector<std::string> truths;
  for (const v1::Metric& m : r.metrics()) {
    if (std::find(truths.begin(), truths.end(), m.ground_truth()) ==
        truths.end()) {
      truths.push_back(m.ground_truth());
    }
  }
  for (const std::string& truth : truths) {
    const v1::Metric* ldr = nullptr;
    const v1::Metric* best_rmse = nullptr;
    const v1::Metric* best_bad = nullptr;
    std::vector<std::string> worse;
    for (const v1::Metric& m : r.metrics()) {
      if (m.ground_truth() != truth || m.method() == kGroundTruthMethod) {
        continue;
      }
      if (m.method() == "ldr") ldr = &m;
      if (best_rmse == nullptr || m.rmse_px() < best_rmse->rmse_px()) {
        best_rmse = &m;
      }
      if (best_bad == nullptr || m.bad_1() < best_bad->bad_1()) best_bad = &m;
      if (m.worse_than_ldr()) {
        worse.push_back(absl::StrFormat("%s (%.3f)", m.method(), m.rmse_px()));
      }
    }
    if (best_rmse == nullptr) continue;
    std::cout << absl::StrFormat(
        "against %s: best by RMSE %s (%.3f px), best by bad-1 %s (%.1f%%)",
        truth, best_rmse->method(), best_rmse->rmse_px(), best_bad->method(),
        best_bad->bad_1());
    if (ldr != nullptr) {
      std::cout << absl::StrFormat("; LDR %.3f px, %.1f%%", ldr->rmse_px(),
                                   ldr->bad_1());
    }
    std::cout << "\n";
    if (!worse.empty()) {
      std::cout << absl::StrFormat("against %s, worse than LDR by RMSE: %s\n",
                                   truth, absl::StrJoin(worse, ", "));
    }
  }
}

int PrintMetrics(const Client& client, const std::string& session) {
  v1::ListMetricsRequest request;
  request.set_session(session);
  v1::ListMetricsResponse response;
  grpc::Status status =
      v1::Sessions::NewStub(client.channel())
          ->ListMetrics(client.NewContext().get(), request, &response);
  return Finish(
      client, status, response, [&session](const v1::ListMetricsResponse& r) {
        if (r.metrics().empty()) {
          std::cout << "no metrics for session " << session
                    << " (process it first; metrics need a "
                       "ground truth)\n";
          return;
        }
        PrintMetricsHeadline(r);
        Table table({"GROUND TRUTH", "METHOD", "RMSE", "MAE", "BAD>0.5",
                     "BAD>1", "BAD>2", "BAD>4", "COVERAGE", "VS LDR"});
        for (const v1::Metric& m : r.metrics()) {
          table.AddRow({m.ground_truth(), m.method(),
                        absl::StrFormat("%.3f", m.rmse_px()),
                        absl::StrFormat("%.3f", m.mae_px()),
                        absl::StrFormat("%.1f%%", m.bad_0_5()),
                        absl::StrFormat("%.1f%%", m.bad_1()),
                        absl::StrFormat("%.1f%%", m.bad_2()),
                        absl::StrFormat("%.1f%%", m.bad_4()),
                        absl::StrFormat("%.1f%%", m.coverage()),
                        m.worse_than_ldr() ? "worse" : ""});
        }
        table.Print(std::cout);
      });
}

int RunProcess(const Client& client, const std::string& session,
               const std::string& steps, bool force, bool watch) {
  v1::SubmitProcessingRequest request;
  request.set_session(session);
  for (absl::string_view step :
       absl::StrSplit(steps, ',', absl::SkipWhitespace())) {
    request.add_steps(std::string(step));
  }
  request.set_force(force);
  v1::Job job;
  grpc::Status status =
      v1::Jobs::NewStub(client.channel())
          ->SubmitProcessing(client.NewContext().get(), request, &job);
  if (!status.ok()) return client.Fail(status);
  if (client.options().json) {
    PrintJson(std::cout, job);
  } else {
    std::cout << "job " << job.id() << " queued: processing session "
              << job.session() << " (" << job.progress().total() << " steps)\n";
  }
  if (!watch) return kExitOk;
  const int rc = WatchJob(client, job.id());
  if (rc != kExitOk || client.options().json) return rc;
  return PrintMetrics(client, session);
}

// Polls the batch's jobs until every one has ended: a line per session when
// its state or step changes, then a total line. Exit code: OK only when
// every job succeeded.
int WatchBatch(const Client& client, std::vector<v1::Job> jobs) {
  auto stub = v1::Jobs::NewStub(client.channel());
  std::vector<std::string> shown(jobs.size());
  for (;;) {
    std::map<std::string, int> counts;
    for (size_t i = 0; i < jobs.size(); ++i) {
      v1::Job& job = jobs[i];
      if (!IsFinal(job.state())) {
        v1::GetJobRequest request;
        request.set_job_id(job.id());
        grpc::Status status =
            stub->Get(client.NewContext().get(), request, &job);
        if (!status.ok()) return client.Fail(status);
      }
      std::string line = absl::StrFormat(
          "%-24s job %-6d %-9s %d/%d %s", job.session(), job.id(),
          StateName(job.state()), job.progress().done(), job.progress().total(),
          job.state() == v1::JOB_STATE_FAILED ? job.error()
                                              : job.progress().step());
      if (line != shown[i]) {
        std::cout << line << "\n";
        shown[i] = line;
      }
      ++counts[StateName(job.state())];
    }
    const int ended =
        counts["succeeded"] + counts["failed"] + counts["cancelled"];
    if (ended == static_cast<int>(jobs.size())) {
      std::cout << absl::StrFormat(
          "total: %d sessions, %d succeeded, %d failed, %d cancelled\n",
          jobs.size(), counts["succeeded"], counts["failed"],
          counts["cancelled"]);
      return counts["succeeded"] == static_cast<int>(jobs.size()) ? kExitOk
                                                                  : kExitError;
    }
    std::cout << absl::StrFormat(
                     "total: %d of %d ended (%d running, %d queued)", ended,
                     jobs.size(), counts["running"], counts["queued"])
              << std::endl;
    std::this_thread::sleep_for(std::chrono::seconds(1));
  }
}

int RunProcessBatch(const Client& client,
                    const std::vector<std::string>& sessions, bool all,
                    const std::string& steps, bool force, bool watch) {
  v1::SubmitProcessingBatchRequest request;
  for (const std::string& s : sessions) request.add_sessions(s);
  request.set_all_sessions(all);
  for (absl::string_view step :
       absl::StrSplit(steps, ',', absl::SkipWhitespace())) {
    request.add_steps(std::string(step));
  }
  request.set_force(force);
  v1::SubmitProcessingBatchResponse response;
  grpc::Status status = v1::Jobs::NewStub(client.channel())
                            ->SubmitProcessingBatch(client.NewContext().get(),
                                                    request, &response);
  if (!status.ok()) return client.Fail(status);
  if (client.options().json) {
    PrintJson(std::cout, response);
  } else {
    for (const v1::Job& job : response.jobs()) {
      std::cout << "job " << job.id() << " queued: processing session "
                << job.session() << "\n";
    }
    for (const auto& skipped : response.skipped()) {
      std::cerr << "skipped " << skipped.session() << ": " << skipped.reason()
                << "\n";
    }
  }
  if (!watch || response.jobs().empty()) return kExitOk;
  return WatchBatch(client, {response.jobs().begin(), response.jobs().end()});
}

grpc::Status ListAll(const Client& client, const std::string& session,
                     const std::string& kind, std::vector<v1::Artifact>* out) {
  auto stub = v1::Sessions::NewStub(client.channel());
  v1::ListArtifactsRequest request;
  request.set_session(session);
  request.set_kind(kind);
  do {
    v1::ListArtifactsResponse page;
    grpc::Status status =
        stub->ListArtifacts(client.NewContext().get(), request, &page);
    if (!status.ok()) return status;
    out->insert(out->end(), page.artifacts().begin(), page.artifacts().end());
    request.mutable_page()->set_page_token(page.next_page_token());
  } while (!request.page().page_token().empty());
  return grpc::Status::OK;
}

int RunArtifacts(const Client& client, const std::string& session,
                 const std::string& kind) {
  std::vector<v1::Artifact> artifacts;
  if (grpc::Status s = ListAll(client, session, kind, &artifacts); !s.ok()) {
    return client.Fail(s);
  }
  v1::ListArtifactsResponse all;
  for (const v1::Artifact& a : artifacts) *all.add_artifacts() = a;
  return Finish(client, grpc::Status::OK, all,
                [](const v1::ListArtifactsResponse& r) {
                  if (r.artifacts().empty()) {
                    std::cout << "no artifacts\n";
                    return;
                  }
                  Table table({"ID", "KIND", "SIZE", "JOB", "PATH"});
                  for (const v1::Artifact& a : r.artifacts()) {
                    table.AddRow({absl::StrCat(a.id()), a.kind(),
                                  absl::StrCat(a.size_bytes()),
                                  absl::StrCat(a.job_id()), a.path()});
                  }
                  table.Print(std::cout);
                });
}

std::string Sha256OfFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> ctx(EVP_MD_CTX_new(),
                                                              EVP_MD_CTX_free);
  EVP_DigestInit_ex(ctx.get(), EVP_sha256(), nullptr);
  std::vector<char> buffer(1 << 16);
  while (in.read(buffer.data(), buffer.size()) || in.gcount() > 0) {
    EVP_DigestUpdate(ctx.get(), buffer.data(), in.gcount());
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_DigestFinal_ex(ctx.get(), digest, &length);
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) {
    absl::StrAppendFormat(&hex, "%02x", digest[i]);
  }
  return hex;
}

// Fetches one artifact to `to/<path>`. An interrupted download leaves
// `<file>.part`, which the next call continues from its size; the file gets
// its name only once its sha256 matches the server's.
grpc::Status Download(const Client& client, const std::string& session,
                      const v1::Artifact& artifact, const fs::path& to) {
  const fs::path target = to / artifact.path();
  if (fs::exists(target) && Sha256OfFile(target) == artifact.sha256()) {
    return grpc::Status::OK;  // already here
  }
  std::error_code ec;
  fs::create_directories(target.parent_path(), ec);
  const fs::path part = fs::path(target.string() + ".part");
  int64_t offset =
      fs::exists(part) ? static_cast<int64_t>(fs::file_size(part)) : 0;
  if (offset > artifact.size_bytes()) {
    fs::remove(part, ec);
    offset = 0;
  }
  std::ofstream out(part, std::ios::binary | std::ios::app);
  if (!out) {
    return grpc::Status(grpc::StatusCode::UNKNOWN,
                        absl::StrCat("cannot write ", part.string()));
  }
  std::unique_ptr<grpc::ClientContext> context = client.NewStreamContext();
  v1::DownloadArtifactRequest request;
  request.set_session(session);
  request.set_artifact_id(artifact.id());
  request.set_offset_bytes(offset);
  auto reader = v1::Sessions::NewStub(client.channel())
                    ->DownloadArtifact(context.get(), request);
  v1::ArtifactChunk chunk;
  while (reader->Read(&chunk)) {
    if (chunk.offset_bytes() != offset) {
      context->TryCancel();
      return grpc::Status(grpc::StatusCode::DATA_LOSS,
                          absl::StrCat(artifact.path(), ": expected bytes at ",
                                       offset, ", got ", chunk.offset_bytes()));
    }
    out.write(chunk.data().data(),
              static_cast<std::streamsize>(chunk.data().size()));
    offset += static_cast<int64_t>(chunk.data().size());
  }
  grpc::Status status = reader->Finish();
  out.close();
  if (!status.ok()) return status;
  if (!out) {
    return grpc::Status(grpc::StatusCode::UNKNOWN,
                        absl::StrCat("cannot write ", part.string()));
  }
  if (Sha256OfFile(part) != artifact.sha256()) {
    fs::remove(part, ec);
    return grpc::Status(grpc::StatusCode::DATA_LOSS,
                        absl::StrCat(artifact.path(),
                                     ": sha256 does not match the server's; "
                                     "download it again"));
  }
  fs::rename(part, target, ec);
  if (ec) {
    return grpc::Status(
        grpc::StatusCode::UNKNOWN,
        absl::StrCat("cannot rename ", part.string(), ": ", ec.message()));
  }
  return grpc::Status::OK;
}

int RunDownload(const Client& client, const std::string& session,
                const std::string& kind, const fs::path& to) {
  std::vector<v1::Artifact> artifacts;
  if (grpc::Status s =
          ListAll(client, session, kind == "all" ? "" : kind, &artifacts);
      !s.ok()) {
    return client.Fail(s);
  }
  if (artifacts.empty()) {
    std::cerr << "hdrstereo: session " << session << " has no "
              << (kind == "all" ? "" : kind + " ")
              << "artifacts; process it first\n";
    return kExitNotFound;
  }
  int64_t bytes = 0;
  for (const v1::Artifact& a : artifacts) {
    if (grpc::Status s = Download(client, session, a, to); !s.ok()) {
      return client.Fail(s);
    }
    bytes += a.size_bytes();
  }
  std::cout << absl::StrFormat("downloaded %d artifacts (%d bytes) to %s\n",
                               artifacts.size(), bytes, to.string());
  return kExitOk;
}

int RunReport(const Client& client, const std::string& session, bool open) {
  std::vector<v1::Artifact> reports;
  if (grpc::Status s = ListAll(client, session, "report", &reports); !s.ok()) {
    return client.Fail(s);
  }
  const v1::Artifact* page = nullptr;
  for (const v1::Artifact& a : reports) {
    if (fs::path(a.path()).filename() == "index.html") page = &a;
  }
  if (page == nullptr) {
    std::cerr << "hdrstereo: session " << session
              << " has no report yet; run: hdrstereo process " << session
              << " --steps report\n";
    return kExitNotFound;
  }
  v1::GetSessionRequest request;
  request.set_name(session);
  v1::Session info;
  grpc::Status status = v1::Sessions::NewStub(client.channel())
                            ->Get(client.NewContext().get(), request, &info);
  if (!status.ok()) return client.Fail(status);
  const fs::path path = fs::path(info.path()) / page->path();
  std::cout << path.string() << "\n";
  if (!fs::exists(path)) {
    std::cerr << "hdrstereo: the report is on the server's disk; fetch it "
                 "with: hdrstereo download "
              << session << " --kind report --to DIR\n";
    return kExitOk;
  }
  std::cout << "file://" << path.string() << "\n";
  if (open && std::getenv("DISPLAY") != nullptr) {
    const std::string command =
        absl::StrCat("xdg-open 'file://", path.string(), "' >/dev/null 2>&1 &");
    if (std::system(command.c_str()) != 0) {
      std::cerr << "hdrstereo: could not start a browser (xdg-open)\n";
    }
  }
  return kExitOk;
}

}  // namespace

void AddProcessingCommands(CLI::App& app, const GlobalOptions& options,
                           int* exit_code) {
  struct Args {
    std::string session;
    std::vector<std::string> sessions;
    bool all = false;
    std::string steps;
    bool force = false;
    bool watch = false;
    std::string kind;
    std::string to;
    bool open = false;
  };
  auto args = std::make_shared<Args>();

  CLI::App* process = app.add_subcommand(
      "process",
      "Process a session (or, with --sessions or --all, many): HDR, tone "
      "mapping, stereo, fusion, ground truth, metrics, export and report");
  CLI::Option* one = process->add_option("SESSION", args->session);
  CLI::Option* many =
      process
          ->add_option("--sessions", args->sessions,
                       "Sessions by name or glob, e.g. 'nightly-2026-*' "
                       "(comma-separated or repeated): one job each")
          ->delimiter(',')
          ->excludes(one);
  process->add_flag("--all", args->all, "Every session: one job each")
      ->excludes(one)
      ->excludes(many);
  process->add_option("--steps", args->steps,
                      "Comma-separated steps (default: all); the steps they "
                      "need are added");
  process->add_flag("--force", args->force, "Recompute even what is unchanged");
  process->add_flag("--watch", args->watch,
                    "Follow the job, then print the metrics");
  process->callback([&options, exit_code, args] {
    if (!args->sessions.empty() || args->all) {
      *exit_code = RunProcessBatch(Client(options), args->sessions, args->all,
                                   args->steps, args->force, args->watch);
      return;
    }
    if (args->session.empty()) {
      std::cerr << "hdrstereo process: name a SESSION, or --sessions or "
                   "--all\n";
      *exit_code = kExitUsage;
      return;
    }
    *exit_code = RunProcess(Client(options), args->session, args->steps,
                            args->force, args->watch);
  });

  CLI::App* metrics =
      app.add_subcommand("metrics", "Print a session's evaluation table");
  metrics->add_option("SESSION", args->session)->required();
  metrics->callback([&options, exit_code, args] {
    *exit_code = PrintMetrics(Client(options), args->session);
  });

  CLI::App* artifacts =
      app.add_subcommand("artifacts", "List what processing produced");
  artifacts->add_option("SESSION", args->session)->required();
  artifacts->add_option("--kind", args->kind, "Only this kind");
  artifacts->callback([&options, exit_code, args] {
    *exit_code = RunArtifacts(Client(options), args->session, args->kind);
  });

  CLI::App* download = app.add_subcommand(
      "download", "Fetch artifacts (resumable, sha256-checked)");
  download->add_option("SESSION", args->session)->required();
  download->add_option("--kind", args->kind,
                       "report, disparity, ... or all (default)");
  download->add_option("--to", args->to, "Local folder")->required();
  download->callback([&options, exit_code, args] {
    *exit_code = RunDownload(Client(options), args->session,
                             args->kind.empty() ? "all" : args->kind, args->to);
  });

  CLI::App* report =
      app.add_subcommand("report", "Print where a session's report is");
  report->add_option("SESSION", args->session)->required();
  report->add_flag("--open", args->open,
                   "Also open it in a browser when there is a display");
  report->callback([&options, exit_code, args] {
    *exit_code = RunReport(Client(options), args->session, args->open);
  });
}

}  // namespace hdrstereo::cli
