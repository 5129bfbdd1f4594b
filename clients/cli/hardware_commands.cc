// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereo hw status|camera|stage|projector|lock|unlock`: direct control
// of the rig and its lock (`hw preview` and `hw projector probe` are in
// rig_commands.cc).
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "clients/cli/commands.h"
#include "clients/cli/exposure.h"
#include "clients/cli/output.h"
#include "clients/cli/time_args.h"
#include "hdrstereo/v1/hardware.grpc.pb.h"

namespace hdrstereo::cli {
namespace {

std::string StateName(v1::DeviceState state) {
  std::string name = v1::DeviceState_Name(state);
  return absl::AsciiStrToLower(
      name.substr(std::string("DEVICE_STATE_").size()));
}

void PrintStage(const v1::StageStatus& s) {
  PrintFields(std::cout,
              {{"stage", StateName(s.state())},
               {"position", absl::StrFormat("%.3f mm of %.1f mm",
                                            s.position_mm(), s.travel_mm())},
               {"homed", s.homed() ? "yes" : "no"},
               {"warnings", s.warning_flags().empty()
                                ? "none"
                                : absl::StrJoin(s.warning_flags(), " ")}});
}

void PrintProjector(const v1::ProjectorStatus& p) {
  PrintFields(std::cout,
              {{"projector", StateName(p.state())},
               {"resolution", absl::StrCat(p.width_px(), "x", p.height_px())},
               {"showing", p.showing()}});
}

void PrintSettings(const v1::CameraSettings& s) {
  PrintFields(
      std::cout,
      {{"exposure", FormatExposure(s.exposure_s())},
       {"iso", s.iso() > 0 ? absl::StrCat(s.iso()) : "unknown"},
       {"aperture", s.aperture_f() > 0 ? absl::StrFormat("f/%g", s.aperture_f())
                                       : "unknown"},
       {"format", v1::ImageFormat_Name(s.format())}});
}

std::string DescribeLock(const v1::RigLock& lock) {
  if (!lock.locked()) return "free";
  return absl::StrCat("locked by ", lock.holder(), " until ",
                      FormatTime(lock.expire_time()),
                      lock.note().empty() ? "" : ": ", lock.note());
}

void PrintLock(const v1::RigLock& lock) {
  std::cout << "rig " << DescribeLock(lock) << "\n";
}

// "  PTP/IP 192.168.1.20" for a camera on the network (libgphoto2 port
// "ptpip:ADDRESS[:PORTS]"), "" for any other.
std::string NetworkCamera(absl::string_view port) {
  if (!absl::ConsumePrefix(&port, "ptpip:")) return "";
  return absl::StrCat("  PTP/IP ", port.substr(0, port.find(':')));
}

int RunStatus(const Client& client) {
  auto stub = v1::Hardware::NewStub(client.channel());
  v1::HardwareStatus status;
  grpc::Status rpc = stub->GetStatus(client.NewContext().get(), {}, &status);
  if (!rpc.ok()) return client.Fail(rpc);
  v1::RigLock lock;
  rpc = stub->GetLock(client.NewContext().get(), {}, &lock);
  if (!rpc.ok()) return client.Fail(rpc);
  if (client.options().json) {
    PrintJson(std::cout, status);
    return kExitOk;
  }
  const v1::CameraStatus& c = status.camera();
  const v1::StageStatus& s = status.stage();
  const v1::ProjectorStatus& p = status.projector();
  PrintFields(
      std::cout,
      {{"mode", status.hardware_mode()},
       {"camera",
        c.state() == v1::DEVICE_STATE_RECONNECTING
            ? absl::StrCat("reconnecting (attempt ", c.reconnect_attempt(), ")",
                           c.message().empty() ? "" : "  ", c.message())
            : absl::StrCat(StateName(c.state()), "  ", c.model(), " ",
                           c.serial(), NetworkCamera(c.port()),
                           c.message().empty() ? "" : "  ", c.message())},
       {"stage",
        absl::StrCat(
            StateName(s.state()), "  ",
            absl::StrFormat("%.3f mm", s.position_mm()),
            s.homed() ? " homed" : " not homed",
            s.warning_flags().empty()
                ? ""
                : absl::StrCat(" [", absl::StrJoin(s.warning_flags(), " "),
                               "]"),
            s.message().empty() ? "" : "  ", s.message())},
       {"projector",
        absl::StrCat(StateName(p.state()), "  ", p.width_px(), "x",
                     p.height_px(), "  ", p.showing(),
                     p.message().empty() ? "" : "  ", p.message())},
       {"lock", DescribeLock(lock)}});
  return kExitOk;
}

}  // namespace

void AddHardwareCommands(CLI::App& app, const GlobalOptions& options,
                         int* exit_code) {
  CLI::App* hw =
      app.add_subcommand("hw", "Direct control of camera, stage, projector");
  hw->require_subcommand(1);
  struct Args {
    std::string exposure;
    int iso = 0;
    double aperture = 0;
    std::string format;
    double position_mm = 0;
    std::string png;
    std::string gray;
    int level = -1;
    std::string ttl = "1h";
    std::string note;
    bool force = false;
  };
  auto args = std::make_shared<Args>();

  hw->add_subcommand("status", "State of every device")
      ->callback(
          [&options, exit_code] { *exit_code = RunStatus(Client(options)); });

  CLI::App* camera = hw->add_subcommand("camera", "Camera settings");
  camera->require_subcommand(1);
  camera->add_subcommand("get", "Show the camera's settings")
      ->callback([&options, exit_code] {
        Client client(options);
        v1::CameraSettings settings;
        grpc::Status rpc =
            v1::Hardware::NewStub(client.channel())
                ->GetCameraSettings(client.NewContext().get(), {}, &settings);
        *exit_code = Finish(client, rpc, settings, PrintSettings);
      });
  CLI::App* set =
      camera->add_subcommand("set", "Change exposure, ISO, aperture, format");
  set->add_option("--exposure", args->exposure, "e.g. 1/125, 0.5, 2")
      ->required();
  set->add_option("--iso", args->iso, "ISO speed");
  set->add_option("--aperture", args->aperture, "f-number, e.g. 8");
  set->add_option("--format", args->format, "Image format")
      ->check(CLI::IsMember({"jpeg", "raw", "raw+jpeg", "tiff16", "png8"}));
  set->callback([&options, exit_code, args] {
    Client client(options);
    absl::StatusOr<double> exposure = ParseExposure(args->exposure);
    if (!exposure.ok()) {
      std::cerr << "hdrstereo: " << exposure.status().message() << "\n";
      *exit_code = kExitUsage;
      return;
    }
    v1::SetCameraSettingsRequest request;
    v1::CameraSettings* s = request.mutable_settings();
    s->set_exposure_s(*exposure);
    s->set_iso(args->iso);
    s->set_aperture_f(args->aperture);
    static const std::map<std::string, v1::ImageFormat> kFormats = {
        {"jpeg", v1::IMAGE_FORMAT_JPEG},
        {"raw", v1::IMAGE_FORMAT_RAW},
        {"raw+jpeg", v1::IMAGE_FORMAT_RAW_AND_JPEG},
        {"tiff16", v1::IMAGE_FORMAT_TIFF_16},
        {"png8", v1::IMAGE_FORMAT_PNG_8}};
    if (!args->format.empty()) s->set_format(kFormats.at(args->format));
    v1::CameraSettings applied;
    grpc::Status rpc =
        v1::Hardware::NewStub(client.channel())
            ->SetCameraSettings(client.NewContext().get(), request, &applied);
    *exit_code = Finish(client, rpc, applied, PrintSettings);
  });

  CLI::App* stage = hw->add_subcommand("stage", "Home or move the stage");
  stage->require_subcommand(1);
  stage->add_subcommand("home", "Home the stage")
      ->callback([&options, exit_code] {
        Client client(options);
        v1::StageStatus status;
        grpc::Status rpc =
            v1::Hardware::NewStub(client.channel())
                ->HomeStage(client.NewContext().get(), {}, &status);
        *exit_code = Finish(client, rpc, status, PrintStage);
      });
  CLI::App* move =
      stage->add_subcommand("move", "Move to an absolute position");
  move->add_option("MM", args->position_mm, "Target position in mm")
      ->required();
  move->callback([&options, exit_code, args] {
    Client client(options);
    v1::MoveStageRequest request;
    request.set_position_mm(args->position_mm);
    v1::StageStatus status;
    grpc::Status rpc =
        v1::Hardware::NewStub(client.channel())
            ->MoveStage(client.NewContext().get(), request, &status);
    *exit_code = Finish(client, rpc, status, PrintStage);
  });

  CLI::App* projector = hw->add_subcommand("projector", "Show patterns");
  projector->require_subcommand(1);
  CLI::App* show = projector->add_subcommand(
      "show", "Show a PNG, a Gray-code plane or a level");
  show->add_option("PNG", args->png, "8-bit PNG at the projector's resolution");
  show->add_option("--gray", args->gray,
                   "Gray-code plane: col:BIT[:inv] or row:BIT[:inv]");
  show->add_option("--level", args->level, "Uniform gray level 0..255");
  show->callback([&options, exit_code, args] {
    Client client(options);
    v1::ShowPatternRequest request;
    const int given =
        !args->png.empty() + !args->gray.empty() + (args->level >= 0);
    if (given != 1) {
      std::cerr << "hdrstereo: give exactly one of PNG, --gray or --level\n";
      *exit_code = kExitUsage;
      return;
    }
    if (!args->png.empty()) {
      std::ifstream in(args->png, std::ios::binary);
      if (!in) {
        std::cerr << "hdrstereo: cannot read " << args->png << "\n";
        *exit_code = kExitUsage;
        return;
      }
      std::ostringstream bytes;
      bytes << in.rdbuf();
      request.set_png(bytes.str());
    } else if (!args->gray.empty()) {
      std::vector<std::string> parts = absl::StrSplit(args->gray, ':');
      int bit = -1;
      if (parts.size() < 2 || parts.size() > 3 ||
          (parts[0] != "col" && parts[0] != "row") ||
          !absl::SimpleAtoi(parts[1], &bit) ||
          (parts.size() == 3 && parts[2] != "inv")) {
        std::cerr << "hdrstereo: --gray \"" << args->gray
                  << "\" is not col:BIT[:inv] or row:BIT[:inv]\n";
        *exit_code = kExitUsage;
        return;
      }
      v1::GrayCodePattern* g = request.mutable_gray_code();
      g->set_axis(parts[0] == "col" ? v1::GrayCodePattern::AXIS_COLUMNS
                                    : v1::GrayCodePattern::AXIS_ROWS);
      g->set_bit(bit);
      g->set_inverse(parts.size() == 3);
    } else {
      request.set_solid_level(args->level);
    }
    v1::ProjectorStatus status;
    grpc::Status rpc =
        v1::Hardware::NewStub(client.channel())
            ->ShowPattern(client.NewContext().get(), request, &status);
    *exit_code = Finish(client, rpc, status, PrintProjector);
  });
  projector->add_subcommand("blank", "Show black")
      ->callback([&options, exit_code] {
        Client client(options);
        v1::ProjectorStatus status;
        grpc::Status rpc =
            v1::Hardware::NewStub(client.channel())
                ->BlankProjector(client.NewContext().get(), {}, &status);
        *exit_code = Finish(client, rpc, status, PrintProjector);
      });

  AddRigCommands(*hw, *projector, options, exit_code);

  CLI::App* lock = hw->add_subcommand(
      "lock",
      "Keep others off the rig while you work at it (not access control)");
  lock->add_option("--ttl", args->ttl, "How long, e.g. 30m, 2h (at most 7d)")
      ->capture_default_str();
  lock->add_option("--note", args->note,
                   "Why, for the people refused, e.g. \"re-aligning the "
                   "projector\"");
  lock->callback([&options, exit_code, args] {
    Client client(options);
    absl::StatusOr<absl::Duration> ttl = ParseDurationArg(args->ttl);
    if (!ttl.ok()) {
      std::cerr << "hdrstereo: --ttl: " << ttl.status().message() << "\n";
      *exit_code = kExitUsage;
      return;
    }
    v1::LockRequest request;
    request.set_note(args->note);
    request.set_ttl_s(absl::ToInt64Seconds(*ttl));
    v1::RigLock state;
    grpc::Status rpc = v1::Hardware::NewStub(client.channel())
                           ->Lock(client.NewContext().get(), request, &state);
    *exit_code = Finish(client, rpc, state, PrintLock);
  });
  CLI::App* unlock = hw->add_subcommand("unlock", "Release the rig lock");
  unlock->add_flag("--force", args->force,
                   "Release another principal's lock (admin)");
  unlock->callback([&options, exit_code, args] {
    Client client(options);
    v1::UnlockRequest request;
    request.set_force(args->force);
    v1::RigLock state;
    grpc::Status rpc = v1::Hardware::NewStub(client.channel())
                           ->Unlock(client.NewContext().get(), request, &state);
    *exit_code = Finish(client, rpc, state, PrintLock);
  });
}

}  // namespace hdrstereo::cli
