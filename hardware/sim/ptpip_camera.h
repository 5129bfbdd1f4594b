// SPDX-License-Identifier: GPL-3.0-or-later
//
// The simulated camera as a network camera: a PTP/IP responder (CIPA
// DC-005 over TCP, ISO 15740 operations) that libgphoto2's "PTP/IP Camera"
// driver, the gphoto2 command-line client or any PTP/IP client talks to.
//
//   SimWorld world(scene);
//   auto camera = PtpIpCamera::Start(world, {});
//   // libgphoto2: model "PTP/IP Camera", port (*camera)->gphoto2_port(),
//   // e.g. "ptpip:127.0.0.1:40123:40123"
//
// Its frames are SimWorld::Capture's: the world at the stage's position
// with the projector's pattern, at the exposure time, ISO and f-number the
// client set, EXIF-stamped and timed as through SimCamera, so a capture
// through it is scored against the same exact truth.
//
// What it answers (docs/ptpip.md says why each is there):
//   GetDeviceInfo, Open/CloseSession, GetStorageIDs/Info, GetNumObjects,
//   GetObjectHandles/Info, GetObject, DeleteObject, InitiateCapture (then
//   the events ObjectAdded and CaptureComplete), GetDevicePropDesc/Value,
//   SetDevicePropValue for ExposureTime (0x500D, an enumeration of 1/3
//   stops in 1/10000 s), ExposureIndex (ISO 100..6400), FNumber (f/1.4..22)
//   and the read-only BatteryLevel (SimWorld::ReadBattery) and DateTime.
//   No live view: libgphoto2 offers none to a generic PTP/IP camera
//   without PTP 1.1 streams. One storage (the camera's RAM); files stay
//   there until deleted.
//
// The world's camera faults arrive the PTP way: "busy" answers
// InitiateCapture with DeviceBusy; a timeout accepts the capture and never
// announces the file; a disconnect drops both connections mid-capture and
// refuses new ones until SimWorld::ReopenCamera lets the camera back;
// corrupt, previous-file and wrong-exposure frames are delivered as the
// world made them. The scene's camera_faults.ptpip faults (scene.h) add a
// connection dropped in the middle of a file's transfer, a slow transfer
// and a full store.
//
// One client at a time, as on a camera: a new command connection replaces
// the one before (a client that reconnects after a drop must get in).
// Every packet is checked before anything is allocated for it (lengths,
// parameter counts, data phases of at most 64 KiB); a malformed packet, an
// out-of-order data phase, a packet or data phase not complete within
// `io_timeout` of its start, a reply or event the client does not take
// within `io_timeout`, or a first packet not there within 2.5 s closes
// that client's connections and nothing else. Between requests a client
// may stay silent as long as it likes.
#ifndef HDRSTEREO_HARDWARE_SIM_PTPIP_CAMERA_H_
#define HDRSTEREO_HARDWARE_SIM_PTPIP_CAMERA_H_

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "hardware/sim/camera_model.h"
#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {

struct PtpIpCameraOptions {
  ImageFormat format = ImageFormat::kPng;
  // IPv4 address to listen on (libgphoto2 takes only IPv4 addresses) and
  // port; 0 = a free port.
  std::string address = "127.0.0.1";
  int port = 0;
  // How long one packet may take to arrive or to be sent.
  absl::Duration io_timeout = absl::Seconds(10);
  // Payload per Data packet of a file sent to the client.
  size_t chunk_bytes = 1 << 20;
  // The camera's RAM: a capture that does not fit ends in a StoreFull
  // event instead of ObjectAdded.
  uint64_t storage_bytes = uint64_t{4} << 30;
};

class PtpIpCamera {
 public:
  // The model name libgphoto2 must be given (its generic PTP/IP entry).
  static constexpr char kGphoto2Model[] = "PTP/IP Camera";

  // Listens and starts serving. The world must outlive the camera.
  // UNAVAILABLE when the address cannot be bound, INVALID_ARGUMENT for an
  // address that is not IPv4 or a port outside 0..65535.
  static absl::StatusOr<std::unique_ptr<PtpIpCamera>> Start(
      SimWorld& world, PtpIpCameraOptions options);
  ~PtpIpCamera();  // closes every connection and stops its threads
  PtpIpCamera(const PtpIpCamera&) = delete;
  PtpIpCamera& operator=(const PtpIpCamera&) = delete;

  int port() const { return port_; }
  // libgphoto2's port string: "ptpip:ADDRESS:PORT:PORT" (the event port
  // must be given too, or libgphoto2 uses 15740).
  std::string gphoto2_port() const;
  // Command connections accepted so far (a reconnect adds one).
  int64_t connections() const { return connections_.load(); }
  // Files held on the camera now.
  int stored_files() const;
  // Why the camera last closed a client's connections or let a capture
  // go unannounced (a bad packet, a timeout, an injected fault), with the
  // connection number; "" before the first.
  std::string last_event() const;

 private:
  class Session;  // one client's command and event connections
  struct State;   // settings and files shared by the sessions

  PtpIpCamera(SimWorld& world, PtpIpCameraOptions options, int listen_fd,
              int port);
  void AcceptLoop();
  // The first packet of a new connection decides what it is.
  void Admit(int fd);

  SimWorld& world_;
  const PtpIpCameraOptions options_;
  const int listen_fd_;
  const int port_;
  std::unique_ptr<State> state_;
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> connections_{0};
  std::mutex sessions_mu_;
  std::shared_ptr<Session> session_;  // the current client, or null
  std::thread session_thread_;
  uint32_t next_connection_ = 1;
  std::thread accept_thread_;
};

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_PTPIP_CAMERA_H_
