// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo session create|list|show|delete`.
#include <iostream>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "clients/cli/commands.h"
#include "clients/cli/output.h"
#include "hdrstereo/v1/sessions.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

void PrintSession(const v1::Session& session) {
  PrintFields(std::cout,
              {
                  {"name", session.name()},
                  {"note", session.note()},
                  {"created", FormatTime(session.create_time())},
                  {"path", session.path()},
                  {"captures", absl::StrCat(session.capture_count())},
                  {"frames", absl::StrCat(session.frame_count())},
                  {"artifacts", absl::StrCat(session.artifact_count())},
              });
}

int RunCreate(const Client& client, const std::string& name,
              const std::string& note) {
  v1::CreateSessionRequest request;
  request.set_name(name);
  request.set_note(note);
  v1::Session session;
  grpc::Status status =
      v1::Sessions::NewStub(client.channel())
          ->Create(client.NewContext().get(), request, &session);
  return Finish(client, status, session, [](const v1::Session& s) {
    std::cout << "created session " << s.name() << " at " << s.path() << "\n";
  });
}

int RunList(const Client& client) {
  auto stub = v1::Sessions::NewStub(client.channel());
  v1::ListSessionsResponse all;
  v1::ListSessionsRequest request;
  do {
    v1::ListSessionsResponse page;
    grpc::Status status = stub->List(client.NewContext().get(), request, &page);
    if (!status.ok()) return client.Fail(status);
    all.mutable_sessions()->MergeFrom(page.sessions());
    request.mutable_page()->set_page_token(page.next_page_token());
  } while (!request.page().page_token().empty());

  if (client.options().json) {
    PrintJson(std::cout, all);
    return kExitOk;
  }
  if (all.sessions().empty()) {
    std::cout << "no sessions\n";
    return kExitOk;
  }
  Table table({"NAME", "CREATED", "CAPTURES", "FRAMES", "ARTIFACTS", "NOTE"});
  for (const v1::Session& s : all.sessions()) {
    table.AddRow({s.name(), FormatTime(s.create_time()),
                  absl::StrCat(s.capture_count()),
                  absl::StrCat(s.frame_count()),
                  absl::StrCat(s.artifact_count()), s.note()});
  }
  table.Print(std::cout);
  return kExitOk;
}

int RunShow(const Client& client, const std::string& name) {
  v1::GetSessionRequest request;
  request.set_name(name);
  v1::Session session;
  grpc::Status status = v1::Sessions::NewStub(client.channel())
                            ->Get(client.NewContext().get(), request, &session);
  return Finish(client, status, session, PrintSession);
}

int RunDelete(const Client& client, const std::string& name, bool yes) {
  if (!yes) {
    std::cerr << "hdrstereo: deleting session " << name
              << " removes all its frames and results; repeat with --yes\n";
    return kExitUsage;
  }
  v1::DeleteSessionRequest request;
  request.set_name(name);
  v1::DeleteSessionResponse response;
  grpc::Status status =
      v1::Sessions::NewStub(client.channel())
          ->Delete(client.NewContext().get(), request, &response);
  return Finish(
      client, status, response, [&name](const v1::DeleteSessionResponse& r) {
        std::cout << "deleted session " << name << " (" << r.frames_deleted()
                  << " frames, " << r.artifacts_deleted() << " artifacts)\n";
      });
}

}  // namespace

void AddSessionCommands(CLI::App& app, const GlobalOptions& options,
                        int* exit_code) {
  CLI::App* session =
      app.add_subcommand("session", "Create and manage sessions");
  session->require_subcommand(1);

  // Parsed values, owned by the callbacks (and so by the app).
  struct Args {
    std::string name;
    std::string note;
    bool yes = false;
  };
  auto args = std::make_shared<Args>();

  CLI::App* create = session->add_subcommand("create", "Create a session");
  create
      ->add_option("NAME", args->name,
                   "1-64 letters, digits, '-' or '_', starting with a "
                   "letter or digit")
      ->required();
  create->add_option("--note", args->note, "Free-text description");
  create->callback([&options, exit_code, args] {
    *exit_code = RunCreate(Client(options), args->name, args->note);
  });

  session->add_subcommand("list", "List sessions")
      ->callback(
          [&options, exit_code] { *exit_code = RunList(Client(options)); });

  CLI::App* show = session->add_subcommand("show", "Show one session");
  show->add_option("NAME", args->name)->required();
  show->callback([&options, exit_code, args] {
    *exit_code = RunShow(Client(options), args->name);
  });

  CLI::App* remove = session->add_subcommand(
      "delete", "Delete a session with its frames and results");
  remove->add_option("NAME", args->name)->required();
  remove->add_flag("--yes", args->yes, "Confirm the deletion");
  remove->callback([&options, exit_code, args] {
    *exit_code = RunDelete(Client(options), args->name, args->yes);
  });
}

}  // namespace hdrstereo::cli
