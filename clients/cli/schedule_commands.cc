// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo schedule add|list|runs|enable|disable|delete`.
#include <google/protobuf/util/json_util.h>

#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "clients/cli/commands.h"
#include "clients/cli/output.h"
#include "hdrstereo/v1/schedules.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

std::string OutcomeName(v1::ScheduleRun::Outcome outcome) {
  return absl::AsciiStrToLower(v1::ScheduleRun::Outcome_Name(outcome).substr(
      std::string("OUTCOME_").size()));
}

std::string PolicyName(v1::MissedRunPolicy policy) {
  return policy == v1::MISSED_RUN_POLICY_SKIP ? "skip" : "run-once-on-start";
}

std::string NextDue(const v1::Schedule& s) {
  if (!s.enabled()) return "- (disabled)";
  if (!s.has_next_due_time()) return "-";
  return FormatTime(s.next_due_time());
}

void PrintSchedule(const v1::Schedule& s) {
  PrintFields(std::cout,
              {{"schedule", s.name()},
               {"cron", s.cron()},
               {"time zone", s.time_zone()},
               {"enabled", s.enabled() ? "yes" : "no"},
               {"missed runs", PolicyName(s.missed_run_policy())},
               {"session pattern", s.plan().session_pattern()},
               {"created by", s.created_by().empty() ? "-" : s.created_by()},
               {"captures", absl::StrCat(s.plan().captures_size())},
               {"next due", NextDue(s)}});
}

struct Args {
  std::string name;
  std::string cron;
  std::string plan_file;
  std::string time_zone;
  std::string missed = "run-once-on-start";
};

int RunAdd(const Client& client, const Args& args) {
  std::ifstream in(args.plan_file);
  if (!in) {
    std::cerr << "hdrstereo: cannot read --plan " << args.plan_file << "\n";
    return kExitUsage;
  }
  std::stringstream text;
  text << in.rdbuf();
  v1::CreateScheduleRequest request;
  v1::Schedule* schedule = request.mutable_schedule();
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  if (auto status = google::protobuf::util::JsonStringToMessage(
          text.str(), schedule->mutable_plan(), options);
      !status.ok()) {
    std::cerr << "hdrstereo: " << args.plan_file
              << " is not a SchedulePlan: " << status.message() << "\n";
    return kExitUsage;
  }
  schedule->set_name(args.name);
  schedule->set_cron(args.cron);
  schedule->set_time_zone(args.time_zone);
  schedule->set_missed_run_policy(
      args.missed == "skip" ? v1::MISSED_RUN_POLICY_SKIP
                            : v1::MISSED_RUN_POLICY_RUN_ONCE_ON_START);
  v1::Schedule response;
  grpc::Status status =
      v1::Schedules::NewStub(client.channel())
          ->Create(client.NewContext().get(), request, &response);
  return Finish(client, status, response, [](const v1::Schedule& s) {
    std::cout << "added schedule " << s.name() << "\n";
    PrintSchedule(s);
  });
}

int RunList(const Client& client) {
  auto stub = v1::Schedules::NewStub(client.channel());
  v1::ListSchedulesResponse all;
  v1::ListSchedulesRequest request;
  do {
    v1::ListSchedulesResponse page;
    grpc::Status status = stub->List(client.NewContext().get(), request, &page);
    if (!status.ok()) return client.Fail(status);
    all.mutable_schedules()->MergeFrom(page.schedules());
    request.mutable_page()->set_page_token(page.next_page_token());
  } while (!request.page().page_token().empty());
  if (client.options().json) {
    PrintJson(std::cout, all);
    return kExitOk;
  }
  if (all.schedules().empty()) {
    std::cout << "no schedules\n";
    return kExitOk;
  }
  Table table({"NAME", "CRON", "TIME ZONE", "ENABLED", "NEXT DUE",
               "SESSION PATTERN", "CREATED BY"});
  for (const v1::Schedule& s : all.schedules()) {
    table.AddRow({s.name(), s.cron(), s.time_zone(), s.enabled() ? "yes" : "no",
                  NextDue(s), s.plan().session_pattern(),
                  s.created_by().empty() ? "-" : s.created_by()});
  }
  table.Print(std::cout);
  return kExitOk;
}

int RunRuns(const Client& client, const std::string& name) {
  auto stub = v1::Schedules::NewStub(client.channel());
  v1::ListScheduleRunsResponse all;
  v1::ListScheduleRunsRequest request;
  request.set_name(name);
  do {
    v1::ListScheduleRunsResponse page;
    grpc::Status status =
        stub->ListRuns(client.NewContext().get(), request, &page);
    if (!status.ok()) return client.Fail(status);
    all.mutable_runs()->MergeFrom(page.runs());
    request.mutable_page()->set_page_token(page.next_page_token());
  } while (!request.page().page_token().empty());
  if (client.options().json) {
    PrintJson(std::cout, all);
    return kExitOk;
  }
  if (all.runs().empty()) {
    std::cout << "no runs of " << name << " yet\n";
    return kExitOk;
  }
  Table table(
      {"DUE", "STARTED", "OUTCOME", "SESSION", "JOBS", "FOR", "REASON"});
  for (const v1::ScheduleRun& r : all.runs()) {
    table.AddRow({FormatTime(r.due_time()),
                  r.has_start_time() ? FormatTime(r.start_time()) : "-",
                  OutcomeName(r.outcome()),
                  r.session().empty() ? "-" : r.session(),
                  r.job_ids().empty() ? "-" : absl::StrJoin(r.job_ids(), ","),
                  r.caused_by().empty() ? "-" : r.caused_by(),
                  r.reason().empty() ? "-" : r.reason()});
  }
  table.Print(std::cout);
  return kExitOk;
}

int RunSetEnabled(const Client& client, const std::string& name, bool enabled) {
  v1::SetScheduleEnabledRequest request;
  request.set_name(name);
  request.set_enabled(enabled);
  v1::Schedule response;
  grpc::Status status =
      v1::Schedules::NewStub(client.channel())
          ->SetEnabled(client.NewContext().get(), request, &response);
  return Finish(client, status, response, [](const v1::Schedule& s) {
    std::cout << (s.enabled() ? "enabled" : "disabled") << " schedule "
              << s.name() << "; next due " << NextDue(s) << "\n";
  });
}

int RunDelete(const Client& client, const std::string& name) {
  v1::DeleteScheduleRequest request;
  request.set_name(name);
  v1::DeleteScheduleResponse response;
  grpc::Status status =
      v1::Schedules::NewStub(client.channel())
          ->Delete(client.NewContext().get(), request, &response);
  return Finish(client, status, response,
                [&name](const v1::DeleteScheduleResponse&) {
                  std::cout << "deleted schedule " << name
                            << " and its run history (sessions stay)\n";
                });
}

}  // namespace

void AddScheduleCommands(CLI::App& app, const GlobalOptions& options,
                         int* exit_code) {
  CLI::App* schedule =
      app.add_subcommand("schedule", "Scheduled (e.g. nightly) acquisitions");
  schedule->require_subcommand(1);
  auto args = std::make_shared<Args>();

  CLI::App* add = schedule->add_subcommand("add", "Add a schedule");
  add->add_option("NAME", args->name, "Schedule name")->required();
  add->add_option("--cron", args->cron,
                  "5 fields: minute hour day-of-month month day-of-week, "
                  "e.g. \"0 2 * * *\"")
      ->required();
  add->add_option("--plan", args->plan_file,
                  "SchedulePlan as protobuf JSON: sessionPattern, captures, "
                  "processingSteps")
      ->required();
  add->add_option("--tz", args->time_zone,
                  "IANA time zone, e.g. Europe/Berlin [default: UTC]");
  add->add_option("--missed", args->missed,
                  "Due times missed while hdrstereod was down")
      ->check(CLI::IsMember({"skip", "run-once-on-start"}))
      ->capture_default_str();
  add->callback([&options, exit_code, args] {
    *exit_code = RunAdd(Client(options), *args);
  });

  schedule->add_subcommand("list", "List schedules with their next due time")
      ->callback(
          [&options, exit_code] { *exit_code = RunList(Client(options)); });

  CLI::App* runs =
      schedule->add_subcommand("runs", "A schedule's runs, newest first");
  runs->add_option("NAME", args->name)->required();
  runs->callback([&options, exit_code, args] {
    *exit_code = RunRuns(Client(options), args->name);
  });

  for (const char* verb : {"enable", "disable"}) {
    const bool enabled = std::string(verb) == "enable";
    CLI::App* sub = schedule->add_subcommand(
        verb, enabled ? "Enable a schedule (due times from now on run)"
                      : "Disable a schedule");
    sub->add_option("NAME", args->name)->required();
    sub->callback([&options, exit_code, args, enabled] {
      *exit_code = RunSetEnabled(Client(options), args->name, enabled);
    });
  }

  CLI::App* remove = schedule->add_subcommand(
      "delete", "Delete a schedule and its run history");
  remove->add_option("NAME", args->name)->required();
  remove->callback([&options, exit_code, args] {
    *exit_code = RunDelete(Client(options), args->name);
  });
}

}  // namespace hdrstereo::cli
