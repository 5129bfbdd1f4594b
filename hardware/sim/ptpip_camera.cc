// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/ptpip_camera.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <future>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/time/clock.h"
#include "hardware/sim/ptpip_packets.h"

namespace hdrstereo::sim {
namespace {

using ptpip::DatasetWriter;

constexpr uint32_t kStorageId = 0x00010001;
constexpr uint16_t kFormatUndefinedImage = 0x3800;
constexpr uint16_t kFormatExifJpeg = 0x3801;
constexpr uint16_t kFormatPng = 0x380B;
constexpr uint16_t kFormatTiff = 0x380D;
constexpr double kMaxExposureS = 30;

// How often blocked threads look at the stop flag.
constexpr int kPollMs = 100;
// How long a new connection may take to send its first packet.
constexpr absl::Duration kHandshakeTimeout = absl::Milliseconds(2500);

// `fd` moved to a descriptor above 2 (the original closed), so that code
// in this process that closes 0, 1 or 2 by mistake (libgphoto2 closes 0
// at each PTP/IP disconnect, libgphoto2_api.cc) never closes a socket of
// the camera's. The original when it cannot be moved.
int AboveStandardDescriptors(int fd) {
  if (fd < 0 || fd > 2) return fd;
  const int moved = fcntl(fd, F_DUPFD_CLOEXEC, 3);
  if (moved < 0) return fd;
  close(fd);
  return moved;
}

uint16_t FormatCode(ImageFormat format) {
  switch (format) {
    case ImageFormat::kPng:
      return kFormatPng;
    case ImageFormat::kJpeg:
      return kFormatExifJpeg;
    case ImageFormat::kTiff16:
      return kFormatTiff;
    case ImageFormat::kDng:
      return kFormatUndefinedImage;  // PTP has no code for DNG
  }
  return kFormatUndefinedImage;
}

// Exposure times in 1/10000 s: the nominal 1/3 stops from 1/4000 s to
// 30 s, rounded to the unit (so 1/800 s is 0.0013 s), duplicates dropped.
const std::vector<uint32_t>& ExposureChoices() {
  static const std::vector<uint32_t>* const choices = [] {
    const double nominal[] = {
        1.0 / 4000, 1.0 / 3200, 1.0 / 2500, 1.0 / 2000,
        1.0 / 1600, 1.0 / 1250, 1.0 / 1000, 1.0 / 800,
        1.0 / 640,  1.0 / 500,  1.0 / 400,  1.0 / 320,
        1.0 / 250,  1.0 / 200,  1.0 / 160,  1.0 / 125,
        1.0 / 100,  1.0 / 80,   1.0 / 60,   1.0 / 50,
        1.0 / 40,   1.0 / 30,   1.0 / 25,   1.0 / 20,
        1.0 / 15,   1.0 / 13,   1.0 / 10,   1.0 / 8,
        1.0 / 6,    1.0 / 5,    1.0 / 4,    0.3,
        0.4,        0.5,        0.6,        0.8,
        1,          1.3,        1.6,        2,
        2.5,        3.2,        4,          5,
        6,          8,          10,         13,
        15,         20,         25,         kMaxExposureS};
    auto* units = new std::vector<uint32_t>;
    for (double s : nominal) {
      const auto u = static_cast<uint32_t>(std::lround(s * 10000));
      if (units->empty() || units->back() != u) units->push_back(u);
    }
    return units;
  }();
  return *choices;
}

const std::vector<uint32_t>& IsoChoices() {
  static const auto* choices = new std::vector<uint32_t>{
      100,  125,  160,  200,  250,  320,  400,  500,  640, 800,
      1000, 1250, 1600, 2000, 2500, 3200, 4000, 5000, 6400};
  return *choices;
}

// f-numbers in 1/100.
const std::vector<uint32_t>& FNumberChoices() {
  static const auto* choices = new std::vector<uint32_t>{
      140, 180, 200,  250,  280,  350,  400,  450,  560,  630, 710,
      800, 900, 1000, 1100, 1300, 1400, 1600, 1800, 2000, 2200};
  return *choices;
}

// "YYYYMMDDThhmmss", PTP's date-time string.
std::string PtpTime(absl::Time t) {
  return absl::FormatTime("%Y%m%dT%H%M%S", t, absl::UTCTimeZone());
}

// Sends all of `bytes` within `timeout`; false when the peer is gone or
// stopped reading.
bool SendAll(int fd, absl::string_view bytes, absl::Duration timeout) {
  const absl::Time deadline = absl::Now() + timeout;
  while (!bytes.empty()) {
    const ssize_t n = send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n > 0) {
      bytes.remove_prefix(static_cast<size_t>(n));
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      return false;
    }
    const absl::Duration left = deadline - absl::Now();
    if (left <= absl::ZeroDuration()) return false;
    pollfd p{fd, POLLOUT, 0};
    poll(&p, 1,
         static_cast<int>(
             std::min<int64_t>(absl::ToInt64Milliseconds(left) + 1, kPollMs)));
  }
  return true;
}

void SetNonBlocking(int fd) {
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL, 0) | O_NONBLOCK);
}

}  // namespace

// What the camera holds across clients: its settings and its files.
struct PtpIpCamera::State {
  struct File {
    std::string bytes;
    std::string name;
    uint16_t format = kFormatUndefinedImage;
    int width = 0;
    int height = 0;
    absl::Time time;
    int64_t capture = 0;  // the InitiateCapture that made it, from 1
  };
  std::mutex mu;
  ExposureSettings settings;  // exposure, ISO, f-number as set
  std::map<uint32_t, File> files;
  uint64_t stored_bytes = 0;
  uint32_t next_handle = 1;
  int64_t captures = 0;  // InitiateCapture calls taken, for fault triggers
  bool capturing = false;
  // A disconnect fault unplugged the camera: connections are refused until
  // SimWorld::ReopenCamera says it is back.
  bool unplugged = false;
  std::string last_event;
};

// One client: its command connection (served on its own thread) and the
// event connection it opens after the handshake.
class PtpIpCamera::Session {
 public:
  Session(PtpIpCamera& camera, int command_fd, uint32_t connection)
      : camera_(camera), command_fd_(command_fd), connection_(connection) {}
  // Owns both connections: they are closed here and only here, so that
  // Close() never shuts down a descriptor number reused by a newer client.
  ~Session() {
    Close();
    if (capture_thread_.joinable()) capture_thread_.join();
    close(command_fd_);
    if (event_fd_ >= 0) close(event_fd_);
  }

  uint32_t connection() const { return connection_; }
  // Takes the event connection and acknowledges it before any event can
  // go out on it; false (and `fd` not taken) when the session has one or
  // is closed, or the acknowledgement could not be sent.
  bool AttachEvents(int fd) {
    std::lock_guard<std::mutex> sending(event_send_mu_);
    {
      std::lock_guard<std::mutex> lock(event_mu_);
      if (event_fd_ >= 0 || closed_) return false;
    }
    if (!SendAll(fd, ptpip::InitEventAckPacket(),
                 camera_.options_.io_timeout)) {
      return false;
    }
    std::lock_guard<std::mutex> lock(event_mu_);
    event_fd_ = fd;
    return true;
  }
  // Ends the client's connections (its thread then returns). Never waits
  // for a send in progress: shutting a socket down ends the send.
  void Close() {
    std::lock_guard<std::mutex> lock(event_mu_);
    closed_ = true;
    shutdown(command_fd_, SHUT_RDWR);
    if (event_fd_ >= 0) shutdown(event_fd_, SHUT_RDWR);
  }
  // Serves requests until the client leaves, Close() or a protocol error.
  void Serve();

 private:
  struct Reply {
    uint16_t code = ptpip::rc::kOk;
    std::vector<uint32_t> params;
    std::optional<std::string> data;  // a data phase to the client
    // Faults on sending `data`.
    bool drop_halfway = false;
    double trickle_s = 0;
  };

  static Reply Answer(uint16_t code) {
    Reply reply;
    reply.code = code;
    return reply;
  }
  static Reply WithData(std::string data) {
    Reply reply;
    reply.data = std::move(data);
    return reply;
  }

  bool Send(absl::string_view bytes) {
    return SendAll(command_fd_, bytes, camera_.options_.io_timeout);
  }
  void SendEvent(uint16_t code, uint32_t transaction,
                 std::vector<uint32_t> params = {});
  // Reads the next packet of the command connection; nullopt when the
  // client left, a packet was bad, `deadline` passed (a packet begun has
  // io_timeout in any case) or the camera stops.
  std::optional<ptpip::Packet> ReadPacket(
      absl::Time deadline = absl::InfiniteFuture());
  // The data phase a request from the client announced.
  std::optional<std::string> ReadDataPhase(uint32_t transaction);
  bool SendReply(uint32_t transaction, const Reply& reply);
  Reply Handle(const ptpip::OperationRequest& request,
               const std::optional<std::string>& data);
  Reply DeviceInfo();
  Reply StorageInfo(uint32_t storage);
  // The handles GetObjectHandles and GetNumObjects answer with (params:
  // storage, format, parent); a response code other than OK when the
  // request names no storage or parent of this camera.
  uint16_t ListHandles(const ptpip::OperationRequest& request,
                       std::vector<uint32_t>* handles);
  Reply ObjectInfo(uint32_t handle);
  Reply GetObject(uint32_t handle);
  Reply DeleteObject(uint32_t handle);
  struct Property;
  // The numeric property `code` as the camera holds it, nullopt for one it
  // does not have; with `read_current` false the current value is left 0
  // (a battery reading is a call the world counts).
  std::optional<Property> PropertyOf(uint16_t code, bool read_current);
  Reply PropDesc(uint16_t code);
  Reply PropValue(uint16_t code);
  Reply SetProp(uint16_t code, const std::string& data);
  Reply InitiateCapture(uint32_t transaction);
  // Keeps a captured file on the camera: its handle, 0 when the store is
  // full.
  uint32_t Store(SimCapture capture, int64_t call);
  // The capture thread: the world's capture, then the events.
  void Capture(uint32_t transaction, ExposureSettings settings, int64_t call,
               std::shared_ptr<std::promise<uint16_t>> answer);
  // Keeps why the camera closed or answered nothing (last_event()).
  void Log(absl::string_view what) {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    camera_.state_->last_event =
        absl::StrCat("connection ", connection_, ": ", what);
  }

  PtpIpCamera& camera_;
  const int command_fd_;
  const uint32_t connection_;
  ptpip::PacketReader reader_;
  bool session_open_ = false;
  uint32_t last_transaction_ = 0;
  std::mutex event_mu_;  // event_fd_ and closed_; never held while sending
  int event_fd_ = -1;
  bool closed_ = false;
  std::mutex event_send_mu_;  // one event on the wire at a time
  std::thread capture_thread_;
};

void PtpIpCamera::Session::SendEvent(uint16_t code, uint32_t transaction,
                                     std::vector<uint32_t> params) {
  std::lock_guard<std::mutex> sending(event_send_mu_);
  int fd = -1;
  {
    std::lock_guard<std::mutex> lock(event_mu_);
    if (event_fd_ < 0 || closed_) return;
    fd = event_fd_;  // closed only in ~Session, after every sender
  }
  if (!SendAll(fd, ptpip::EventPacket(code, transaction, params),
               camera_.options_.io_timeout)) {
    Log("the client stopped reading its events");
    Close();
  }
}

std::optional<ptpip::Packet> PtpIpCamera::Session::ReadPacket(
    absl::Time deadline) {
  char buffer[64 * 1024];
  while (!camera_.stop_.load()) {
    absl::StatusOr<std::optional<ptpip::Packet>> next = reader_.Next();
    if (!next.ok()) {
      Log(next.status().message());
      return std::nullopt;
    }
    if (next->has_value()) return std::move(**next);
    if (reader_.pending() > 0) {
      deadline = std::min(deadline, absl::Now() + camera_.options_.io_timeout);
    }
    if (absl::Now() > deadline) {
      Log("a packet or data phase began but did not arrive in time");
      return std::nullopt;
    }
    pollfd p{command_fd_, POLLIN, 0};
    if (poll(&p, 1, kPollMs) <= 0) continue;
    const ssize_t n = recv(command_fd_, buffer, sizeof(buffer), 0);
    if (n == 0) return std::nullopt;  // the client closed
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) continue;
      return std::nullopt;
    }
    reader_.Append(absl::string_view(buffer, static_cast<size_t>(n)));
  }
  return std::nullopt;
}

std::optional<std::string> PtpIpCamera::Session::ReadDataPhase(
    uint32_t transaction) {
  // The whole data phase (at most 64 KiB) within one I/O timeout.
  const absl::Time deadline = absl::Now() + camera_.options_.io_timeout;
  std::optional<ptpip::Packet> start = ReadPacket(deadline);
  if (!start.has_value()) return std::nullopt;
  if (start->type != ptpip::kStartData) {
    Log(absl::StrCat("packet type ", start->type,
                     " where the request's StartData was due"));
    return std::nullopt;
  }
  absl::StatusOr<ptpip::StartData> header = ptpip::ParseStartData(start->body);
  if (!header.ok() || header->transaction != transaction) {
    Log(header.ok() ? "StartData names another transaction"
                    : header.status().message());
    return std::nullopt;
  }
  if (header->total_bytes > ptpip::kMaxClientDataBytes) {
    Log(absl::StrCat("the client announces ", header->total_bytes,
                     " bytes of data; a property value is at most ",
                     ptpip::kMaxClientDataBytes));
    return std::nullopt;
  }
  std::string data;
  while (data.size() < header->total_bytes) {
    std::optional<ptpip::Packet> packet = ReadPacket(deadline);
    if (!packet.has_value()) return std::nullopt;
    if (packet->type != ptpip::kData && packet->type != ptpip::kEndData) {
      Log(absl::StrCat("packet type ", packet->type, " inside a data phase"));
      return std::nullopt;
    }
    absl::StatusOr<ptpip::DataChunk> chunk =
        ptpip::ParseDataChunk(packet->body);
    if (!chunk.ok() || chunk->transaction != transaction ||
        data.size() + chunk->payload.size() > header->total_bytes) {
      Log("a data packet of another transaction, or more than announced");
      return std::nullopt;
    }
    data.append(chunk->payload.data(), chunk->payload.size());
    if (packet->type == ptpip::kEndData) break;
  }
  if (data.size() != header->total_bytes) {
    Log("the data phase ended short of its announced length");
    return std::nullopt;
  }
  return data;
}

bool PtpIpCamera::Session::SendReply(uint32_t transaction, const Reply& r) {
  if (r.data.has_value()) {
    const std::string& data = *r.data;
    if (!Send(ptpip::StartDataPacket(transaction, data.size()))) return false;
    // Pieces of chunk_bytes; a trickle is cut into at least one piece per
    // second it lasts (so no pause reaches libgphoto2's 2.5 s read
    // timeout), a dropped transfer into at least two (the first half goes).
    const size_t chunk = std::max<size_t>(camera_.options_.chunk_bytes, 1);
    size_t pieces = (data.size() + chunk - 1) / chunk;
    if (r.trickle_s > 0) {
      pieces = std::max(pieces, static_cast<size_t>(std::ceil(r.trickle_s)));
    }
    if (r.drop_halfway) pieces = std::max<size_t>(pieces, 2);
    pieces = std::max<size_t>(pieces, 1);
    const size_t piece =
        std::max<size_t>((data.size() + pieces - 1) / pieces, 1);
    const double pause_s = r.trickle_s / static_cast<double>(pieces);
    size_t at = 0;
    do {
      const size_t n = std::min(piece, data.size() - at);
      if (r.drop_halfway && at > 0 && at >= data.size() / 2) {
        Log("dropping the connection halfway through a transfer (fault)");
        Close();
        return false;
      }
      if (pause_s > 0) camera_.world_.SleepModelled(pause_s);
      const bool last = at + n == data.size();
      if (!Send(ptpip::DataPacket(
              transaction, absl::string_view(data).substr(at, n), last))) {
        return false;
      }
      at += n;
    } while (at < data.size());
  }
  return Send(ptpip::OperationResponsePacket(r.code, transaction, r.params));
}

void PtpIpCamera::Session::Serve() {
  while (!camera_.stop_.load()) {
    std::optional<ptpip::Packet> packet = ReadPacket();
    if (!packet.has_value()) break;
    if (packet->type == ptpip::kProbeRequest) {
      if (!Send(ptpip::ProbeResponsePacket())) break;
      continue;
    }
    if (packet->type != ptpip::kOperationRequest) {
      Log(absl::StrCat("packet type ", packet->type,
                       " where an operation request was due"));
      break;
    }
    absl::StatusOr<ptpip::OperationRequest> request =
        ptpip::ParseOperationRequest(packet->body);
    if (!request.ok()) {
      Log(request.status().message());
      break;
    }
    std::optional<std::string> data;
    if (request->data_phase == ptpip::kFromClient) {
      data = ReadDataPhase(request->transaction);
      if (!data.has_value()) break;
    }
    if (!SendReply(request->transaction, Handle(*request, data))) break;
  }
  Close();
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::Handle(
    const ptpip::OperationRequest& request,
    const std::optional<std::string>& data) {
  const auto param = [&](size_t i) -> uint32_t {
    return i < request.params.size() ? request.params[i] : 0;
  };
  if (request.code == ptpip::op::kOpenSession) {
    if (session_open_) return Answer(ptpip::rc::kSessionAlreadyOpen);
    if (param(0) == 0) return Answer(ptpip::rc::kParameterNotSupported);
    session_open_ = true;
    last_transaction_ = request.transaction;
    return Reply();
  }
  if (request.code == ptpip::op::kGetDeviceInfo) return DeviceInfo();
  if (!session_open_) return Answer(ptpip::rc::kSessionNotOpen);
  // Transactions count up within a session.
  if (request.transaction <= last_transaction_) {
    return Answer(ptpip::rc::kInvalidTransactionId);
  }
  last_transaction_ = request.transaction;
  const bool wants_data = request.code == ptpip::op::kSetDevicePropValue;
  if (wants_data != data.has_value()) {
    return Answer(ptpip::rc::kParameterNotSupported);
  }
  switch (request.code) {
    case ptpip::op::kCloseSession:
      session_open_ = false;
      last_transaction_ = 0;
      return Reply();
    case ptpip::op::kGetStorageIds:
      return WithData(DatasetWriter().U32Array({kStorageId}).bytes());
    case ptpip::op::kGetStorageInfo:
      return StorageInfo(param(0));
    case ptpip::op::kGetNumObjects:
    case ptpip::op::kGetObjectHandles: {
      std::vector<uint32_t> handles;
      const uint16_t listed = ListHandles(request, &handles);
      if (listed != ptpip::rc::kOk) return Answer(listed);
      if (request.code == ptpip::op::kGetObjectHandles) {
        return WithData(DatasetWriter().U32Array(handles).bytes());
      }
      Reply reply;
      reply.params = {static_cast<uint32_t>(handles.size())};
      return reply;
    }
    case ptpip::op::kGetObjectInfo:
      return ObjectInfo(param(0));
    case ptpip::op::kGetObject:
      return GetObject(param(0));
    case ptpip::op::kDeleteObject:
      return DeleteObject(param(0));
    case ptpip::op::kInitiateCapture:
      return InitiateCapture(request.transaction);
    case ptpip::op::kGetDevicePropDesc:
      return PropDesc(static_cast<uint16_t>(param(0)));
    case ptpip::op::kGetDevicePropValue:
      return PropValue(static_cast<uint16_t>(param(0)));
    case ptpip::op::kSetDevicePropValue:
      return SetProp(static_cast<uint16_t>(param(0)), *data);
    default:
      return Answer(ptpip::rc::kOperationNotSupported);
  }
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::DeviceInfo() {
  const Scene& scene = camera_.world_.scene();
  const uint16_t format = FormatCode(camera_.options_.format);
  DatasetWriter w;
  w.U16(100)   // PTP 1.00
      .U32(0)  // no vendor extension: libgphoto2's generic paths
      .U16(0)
      .String("")
      .U16(0)  // functional mode: standard
      .U16Array({ptpip::op::kGetDeviceInfo, ptpip::op::kOpenSession,
                 ptpip::op::kCloseSession, ptpip::op::kGetStorageIds,
                 ptpip::op::kGetStorageInfo, ptpip::op::kGetNumObjects,
                 ptpip::op::kGetObjectHandles, ptpip::op::kGetObjectInfo,
                 ptpip::op::kGetObject, ptpip::op::kDeleteObject,
                 ptpip::op::kInitiateCapture, ptpip::op::kGetDevicePropDesc,
                 ptpip::op::kGetDevicePropValue,
                 ptpip::op::kSetDevicePropValue})
      .U16Array({ptpip::event::kObjectAdded, ptpip::event::kDevicePropChanged,
                 ptpip::event::kStoreFull, ptpip::event::kCaptureComplete})
      .U16Array({ptpip::prop::kBatteryLevel, ptpip::prop::kFNumber,
                 ptpip::prop::kExposureTime, ptpip::prop::kExposureIndex,
                 ptpip::prop::kDateTime})
      .U16Array({format})
      .U16Array({format})
      .String("hdrstereo")
      .String(absl::StrCat("hdrstereo simulated camera (", scene.name, ")"))
      .String("1.0")
      .String(absl::StrCat("sim-", scene.seed));
  return WithData(w.bytes());
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::StorageInfo(
    uint32_t storage) {
  if (storage != kStorageId) return Answer(ptpip::rc::kInvalidStorageId);
  uint64_t used = 0;
  {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    used = camera_.state_->stored_bytes;
  }
  const uint64_t capacity = camera_.options_.storage_bytes;
  DatasetWriter w;
  w.U16(0x0003)     // fixed RAM
      .U16(0x0002)  // generic hierarchical
      .U16(0x0000)  // read-write
      .U64(capacity)
      .U64(capacity - std::min(capacity, used))
      .U32(0xFFFFFFFF)  // free space in images: not used
      .String("RAM")
      .String("");
  return WithData(w.bytes());
}

uint16_t PtpIpCamera::Session::ListHandles(
    const ptpip::OperationRequest& request, std::vector<uint32_t>* handles) {
  const auto param = [&](size_t i) -> uint32_t {
    return i < request.params.size() ? request.params[i] : 0;
  };
  if (param(0) != kStorageId && param(0) != 0xFFFFFFFF) {
    return ptpip::rc::kInvalidStorageId;
  }
  // Every file is in the root: "all" (0) and "the root" (0xFFFFFFFF) list
  // them, a file is no folder.
  if (param(2) != 0 && param(2) != 0xFFFFFFFF) {
    return ptpip::rc::kInvalidParentObject;
  }
  std::lock_guard<std::mutex> lock(camera_.state_->mu);
  for (const auto& [handle, file] : camera_.state_->files) {
    if (param(1) == 0 || param(1) == file.format) handles->push_back(handle);
  }
  return ptpip::rc::kOk;
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::ObjectInfo(uint32_t handle) {
  std::lock_guard<std::mutex> lock(camera_.state_->mu);
  auto it = camera_.state_->files.find(handle);
  if (it == camera_.state_->files.end()) {
    return Answer(ptpip::rc::kInvalidObjectHandle);
  }
  const State::File& f = it->second;
  DatasetWriter w;
  w.U32(kStorageId)
      .U16(f.format)
      .U16(0)  // not protected
      .U32(static_cast<uint32_t>(std::min<uint64_t>(f.bytes.size(),
                                                    0xFFFFFFFF)))
      .U16(0)  // no thumbnail
      .U32(0)
      .U32(0)
      .U32(0)
      .U32(static_cast<uint32_t>(f.width))
      .U32(static_cast<uint32_t>(f.height))
      .U32(f.format == kFormatTiff ? 48 : 24)
      .U32(0)  // parent: the root
      .U16(0)  // no association
      .U32(0)
      .U32(0)
      .String(f.name)
      .String(PtpTime(f.time))
      .String(PtpTime(f.time))
      .String("");
  return WithData(w.bytes());
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::GetObject(uint32_t handle) {
  Reply reply;
  int64_t capture = 0;
  {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    auto it = camera_.state_->files.find(handle);
    if (it == camera_.state_->files.end()) {
      return Answer(ptpip::rc::kInvalidObjectHandle);
    }
    reply.data = it->second.bytes;
    capture = it->second.capture;
  }
  // The transfer faults count the captures that made the files.
  const CameraFaults::PtpIp& faults =
      camera_.world_.scene().camera_faults.ptpip;
  const uint64_t seed = camera_.world_.scene().seed;
  reply.drop_halfway = FaultFires(faults.drop_in_transfer, capture, seed, 21);
  if (FaultFires(faults.slow_transfer, capture, seed, 22)) {
    reply.trickle_s = faults.slow_transfer_s;
  }
  return reply;
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::DeleteObject(
    uint32_t handle) {
  State& state = *camera_.state_;
  std::lock_guard<std::mutex> lock(state.mu);
  if (handle == 0xFFFFFFFF) {
    state.files.clear();
    state.stored_bytes = 0;
    return Reply();
  }
  auto it = state.files.find(handle);
  if (it == state.files.end()) return Answer(ptpip::rc::kInvalidObjectHandle);
  state.stored_bytes -= it->second.bytes.size();
  state.files.erase(it);
  return Reply();
}

// A numeric property: its type, whether it can be set, its current value
// and its choices.
struct PtpIpCamera::Session::Property {
  uint16_t data_type = ptpip::type::kUint16;
  bool settable = true;
  uint32_t current = 0;
  const std::vector<uint32_t>* choices = nullptr;  // null: a 0..100 range

  void Put(DatasetWriter& w, uint32_t v) const {
    if (data_type == ptpip::type::kUint8) w.U8(static_cast<uint8_t>(v));
    if (data_type == ptpip::type::kUint16) w.U16(static_cast<uint16_t>(v));
    if (data_type == ptpip::type::kUint32) w.U32(v);
  }
};

std::optional<PtpIpCamera::Session::Property> PtpIpCamera::Session::PropertyOf(
    uint16_t code, bool read_current) {
  ExposureSettings s;
  {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    s = camera_.state_->settings;
  }
  switch (code) {
    case ptpip::prop::kExposureTime:
      return Property{ptpip::type::kUint32, true,
                      static_cast<uint32_t>(std::lround(s.exposure_s * 10000)),
                      &ExposureChoices()};
    case ptpip::prop::kExposureIndex:
      return Property{ptpip::type::kUint16, true,
                      static_cast<uint32_t>(std::lround(s.iso)), &IsoChoices()};
    case ptpip::prop::kFNumber:
      return Property{ptpip::type::kUint16, true,
                      static_cast<uint32_t>(std::lround(s.aperture_f * 100)),
                      &FNumberChoices()};
    case ptpip::prop::kBatteryLevel:
      return Property{ptpip::type::kUint8, false,
                      read_current ? static_cast<uint32_t>(std::clamp(
                                         camera_.world_.ReadBattery(), 0, 100))
                                   : 0,
                      nullptr};
    default:
      return std::nullopt;
  }
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::PropDesc(uint16_t code) {
  if (code == ptpip::prop::kDateTime) {
    const std::string now = PtpTime(absl::Now());
    DatasetWriter w;
    w.U16(code).U16(ptpip::type::kString).U8(0).String(now).String(now).U8(0);
    return WithData(w.bytes());
  }
  const std::optional<Property> p = PropertyOf(code, /*read_current=*/true);
  if (!p.has_value()) return Answer(ptpip::rc::kDevicePropNotSupported);
  DatasetWriter w;
  w.U16(code).U16(p->data_type).U8(p->settable ? 1 : 0);
  p->Put(w, p->choices == nullptr ? 100 : p->choices->front());
  p->Put(w, p->current);
  if (p->choices == nullptr) {
    w.U8(1);  // range 0..100, step 1
    p->Put(w, 0);
    p->Put(w, 100);
    p->Put(w, 1);
  } else {
    w.U8(2);
    w.U16(static_cast<uint16_t>(p->choices->size()));
    for (uint32_t v : *p->choices) p->Put(w, v);
  }
  return WithData(w.bytes());
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::PropValue(uint16_t code) {
  if (code == ptpip::prop::kDateTime) {
    return WithData(DatasetWriter().String(PtpTime(absl::Now())).bytes());
  }
  const std::optional<Property> p = PropertyOf(code, /*read_current=*/true);
  if (!p.has_value()) return Answer(ptpip::rc::kDevicePropNotSupported);
  DatasetWriter w;
  p->Put(w, p->current);
  return WithData(w.bytes());
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::SetProp(
    uint16_t code, const std::string& data) {
  if (code == ptpip::prop::kDateTime) {
    return Answer(ptpip::rc::kAccessDenied);  // read-only
  }
  const std::optional<Property> p = PropertyOf(code, /*read_current=*/false);
  if (!p.has_value()) return Answer(ptpip::rc::kDevicePropNotSupported);
  if (!p->settable) return Answer(ptpip::rc::kAccessDenied);
  absl::StatusOr<uint32_t> value =
      ptpip::ParseUnsignedValue(p->data_type, data);
  if (!value.ok() || std::find(p->choices->begin(), p->choices->end(),
                               *value) == p->choices->end()) {
    return Answer(ptpip::rc::kInvalidDevicePropValue);
  }
  {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    ExposureSettings& s = camera_.state_->settings;
    if (code == ptpip::prop::kExposureTime) s.exposure_s = *value / 10000.0;
    if (code == ptpip::prop::kExposureIndex) s.iso = *value;
    if (code == ptpip::prop::kFNumber) s.aperture_f = *value / 100.0;
  }
  SendEvent(ptpip::event::kDevicePropChanged, 0, {code});
  return Reply();
}

PtpIpCamera::Session::Reply PtpIpCamera::Session::InitiateCapture(
    uint32_t transaction) {
  ExposureSettings settings;
  int64_t call = 0;
  {
    std::lock_guard<std::mutex> lock(camera_.state_->mu);
    if (camera_.state_->capturing) return Answer(ptpip::rc::kDeviceBusy);
    camera_.state_->capturing = true;
    settings = camera_.state_->settings;
    call = ++camera_.state_->captures;
  }
  if (capture_thread_.joinable()) capture_thread_.join();
  auto answer = std::make_shared<std::promise<uint16_t>>();
  std::future<uint16_t> answered = answer->get_future();
  capture_thread_ =
      std::thread(&Session::Capture, this, transaction, settings, call, answer);
  // The world says at once whether it takes the trigger (busy, or gone);
  // the exposure and the events come after the response.
  return Answer(answered.get());
}

void PtpIpCamera::Session::Capture(
    uint32_t transaction, ExposureSettings settings, int64_t call,
    std::shared_ptr<std::promise<uint16_t>> answer) {
  State& state = *camera_.state_;
  bool answered = false;
  const auto accept = [&] {
    answer->set_value(ptpip::rc::kOk);
    answered = true;
  };
  absl::StatusOr<SimCapture> capture =
      camera_.world_.Capture(settings, camera_.options_.format, accept);
  // The camera takes the next trigger before this one's last events go
  // out: a client may trigger as soon as it reads CaptureComplete, and a
  // DeviceBusy then would leave libgphoto2 waiting for ever. This session's
  // next InitiateCapture joins this thread first, so its events still
  // follow these.
  const auto ready = [&state](bool unplugged) {
    std::lock_guard<std::mutex> lock(state.mu);
    state.capturing = false;
    if (unplugged) state.unplugged = true;
  };
  if (!answered) {
    // Refused before exposing: busy, or the camera is gone.
    ready(absl::IsFailedPrecondition(capture.status()));
    answer->set_value(absl::IsUnavailable(capture.status())
                          ? ptpip::rc::kDeviceBusy
                          : ptpip::rc::kGeneralError);
    return;
  }
  if (absl::IsDeadlineExceeded(capture.status())) {
    ready(false);
    Log("the capture never announces its file (timeout fault)");
    return;
  }
  if (absl::IsAborted(capture.status())) {
    ready(true);
    Log("the camera drops off the network mid-capture (disconnect fault)");
    Close();
    return;
  }
  if (!capture.ok()) {
    ready(false);
    Log(capture.status().message());
    SendEvent(ptpip::event::kCaptureComplete, transaction);
    return;
  }
  const CameraFaults::PtpIp& faults =
      camera_.world_.scene().camera_faults.ptpip;
  const bool store_full =
      FaultFires(faults.store_full, call, camera_.world_.scene().seed, 23);
  const uint32_t handle = store_full ? 0 : Store(*std::move(capture), call);
  // A previous-file fault delivered an older file for this capture and
  // kept the new one: it is taken while this capture still holds the
  // camera (after, it would be the next capture's), and announced after
  // CaptureComplete, so that it waits in the client's event queue
  // (libgphoto2 takes it for the next capture's file unless the driver
  // drains the queue first).
  std::optional<SimCapture> pending;
  if (handle != 0) pending = camera_.world_.TakePendingFile();
  const uint32_t late = pending ? Store(*std::move(pending), call) : 0;
  ready(false);
  if (handle == 0) {
    SendEvent(ptpip::event::kStoreFull, transaction, {kStorageId});
    return;
  }
  SendEvent(ptpip::event::kObjectAdded, transaction, {handle});
  SendEvent(ptpip::event::kCaptureComplete, transaction);
  if (late != 0) SendEvent(ptpip::event::kObjectAdded, 0, {late});
}

uint32_t PtpIpCamera::Session::Store(SimCapture capture, int64_t call) {
  State& state = *camera_.state_;
  std::lock_guard<std::mutex> lock(state.mu);
  if (state.stored_bytes + capture.bytes.size() >
      camera_.options_.storage_bytes) {
    return 0;
  }
  const uint32_t handle = state.next_handle++;
  state.stored_bytes += capture.bytes.size();
  State::File& file = state.files[handle];
  file.bytes = std::move(capture.bytes);
  file.name = capture.file_name;
  file.format = FormatCode(capture.format);
  file.width = capture.image.cols;
  file.height = capture.image.rows;
  file.time = capture.camera_time;
  file.capture = call;
  return handle;
}

absl::StatusOr<std::unique_ptr<PtpIpCamera>> PtpIpCamera::Start(
    SimWorld& world, PtpIpCameraOptions options) {
  in_addr address{};
  if (inet_pton(AF_INET, options.address.c_str(), &address) != 1) {
    return absl::InvalidArgumentError(absl::StrCat(
        "\"", options.address,
        "\" is not an IPv4 address (libgphoto2's PTP/IP takes only those)"));
  }
  if (options.port < 0 || options.port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("port ", options.port, " is outside 0..65535"));
  }
  const int fd =
      AboveStandardDescriptors(socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (fd < 0) {
    return absl::UnavailableError(
        absl::StrCat("socket: ", std::strerror(errno)));
  }
  const int one = 1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_port = htons(static_cast<uint16_t>(options.port));
  sa.sin_addr = address;
  if (bind(fd, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) != 0 ||
      listen(fd, 4) != 0) {
    const int error = errno;
    close(fd);
    return absl::UnavailableError(
        absl::StrCat("cannot listen on ", options.address, ":", options.port,
                     ": ", std::strerror(error)));
  }
  socklen_t length = sizeof(sa);
  getsockname(fd, reinterpret_cast<sockaddr*>(&sa), &length);
  SetNonBlocking(fd);
  return std::unique_ptr<PtpIpCamera>(
      new PtpIpCamera(world, std::move(options), fd, ntohs(sa.sin_port)));
}

PtpIpCamera::PtpIpCamera(SimWorld& world, PtpIpCameraOptions options,
                         int listen_fd, int port)
    : world_(world),
      options_(std::move(options)),
      listen_fd_(listen_fd),
      port_(port),
      state_(std::make_unique<State>()) {
  state_->settings.exposure_s = 80 / 10000.0;  // 1/125 s
  state_->settings.iso = 100;
  state_->settings.aperture_f = 8;
  state_->unplugged = !world_.camera_connected();  // absent from the start
  accept_thread_ = std::thread(&PtpIpCamera::AcceptLoop, this);
}

PtpIpCamera::~PtpIpCamera() {
  stop_ = true;
  accept_thread_.join();
  std::shared_ptr<Session> session;
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    session = session_;
  }
  if (session) session->Close();
  if (session_thread_.joinable()) session_thread_.join();
  close(listen_fd_);
}

std::string PtpIpCamera::gphoto2_port() const {
  return absl::StrCat("ptpip:", options_.address, ":", port_, ":", port_);
}

std::string PtpIpCamera::last_event() const {
  std::lock_guard<std::mutex> lock(state_->mu);
  return state_->last_event;
}

int PtpIpCamera::stored_files() const {
  std::lock_guard<std::mutex> lock(state_->mu);
  return static_cast<int>(state_->files.size());
}

void PtpIpCamera::AcceptLoop() {
  while (!stop_.load()) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (poll(&p, 1, kPollMs) <= 0) continue;
    const int accepted =
        accept4(listen_fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (accepted < 0) {
      // Out of descriptors, say: wait instead of spinning on the backlog.
      if (errno != EAGAIN && errno != EINTR && errno != ECONNABORTED) {
        absl::SleepFor(absl::Milliseconds(kPollMs));
      }
      continue;
    }
    const int fd = AboveStandardDescriptors(accepted);
    const int one = 1;
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    Admit(fd);
  }
}

void PtpIpCamera::Admit(int fd) {
  // The first packet: InitCommandRequest or InitEventRequest, no longer
  // than an init request can be, within the time libgphoto2 itself waits
  // for the answer (a silent peer holds up the next connection that long).
  ptpip::PacketReader reader(1024);
  const absl::Time deadline = absl::Now() + kHandshakeTimeout;
  std::optional<ptpip::Packet> first;
  char buffer[1024];
  while (!stop_.load() && absl::Now() < deadline) {
    absl::StatusOr<std::optional<ptpip::Packet>> next = reader.Next();
    if (!next.ok()) break;
    if (next->has_value()) {
      first = std::move(**next);
      break;
    }
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, kPollMs) <= 0) continue;
    const ssize_t n = recv(fd, buffer, sizeof(buffer), 0);
    if (n <= 0) break;
    reader.Append(absl::string_view(buffer, static_cast<size_t>(n)));
  }
  if (!first.has_value()) {
    close(fd);
    return;
  }
  if (first->type == ptpip::kInitEventRequest) {
    absl::StatusOr<uint32_t> connection =
        ptpip::ParseInitEventRequest(first->body);
    std::shared_ptr<Session> session;
    {
      std::lock_guard<std::mutex> lock(sessions_mu_);
      session = session_;
    }
    if (connection.ok() && session && session->connection() == *connection &&
        session->AttachEvents(fd)) {
      return;  // the session closes it
    }
    SendAll(fd, ptpip::InitFailPacket(1), options_.io_timeout);
    close(fd);
    return;
  }
  absl::StatusOr<ptpip::InitCommandRequest> request =
      first->type == ptpip::kInitCommandRequest
          ? ptpip::ParseInitCommandRequest(first->body)
          : absl::InvalidArgumentError("not an init request");
  bool plugged = request.ok();
  if (plugged) {
    std::lock_guard<std::mutex> lock(state_->mu);
    if (state_->unplugged) {
      // Back once the world lets the camera be found again.
      plugged = world_.ReopenCamera().ok();
      state_->unplugged = !plugged;
    }
  }
  if (!plugged) {
    close(fd);  // a camera that is not there answers nothing
    return;
  }
  const uint32_t connection = next_connection_++;
  static const std::array<uint8_t, 16> kGuid = {
      'h', 'd', 'r', 's', 't', 'e', 'r', 'e', 'o', '-', 's', 'i', 'm', 0, 0, 1};
  if (!SendAll(fd,
               ptpip::InitCommandAckPacket(connection, kGuid,
                                           "hdrstereo simulated camera"),
               options_.io_timeout)) {
    close(fd);
    return;
  }
  // One client at a time: the new one replaces the old. The old one is
  // closed at once, and ended (its thread joined, its capture finished) on
  // the new one's thread, so that the accept thread never waits for it.
  auto session = std::make_shared<Session>(*this, fd, connection);
  std::shared_ptr<Session> old;
  {
    std::lock_guard<std::mutex> lock(sessions_mu_);
    old = std::exchange(session_, session);
  }
  if (old) old->Close();
  ++connections_;
  session_thread_ =
      std::thread([this, session, old = std::move(old),
                   previous = std::move(session_thread_)]() mutable {
        if (previous.joinable()) previous.join();
        old.reset();
        session->Serve();
        std::lock_guard<std::mutex> lock(sessions_mu_);
        if (session_ == session) session_ = nullptr;
      });
}

}  // namespace hdrstereo::sim
