// SPDX-License-Identifier: GPL-3.0-or-later
//
// The simulated PTP/IP camera, checked by a client we did not write:
// Debian's gphoto2 command-line program (libgphoto2's own PTP/IP code)
// reads its summary and settings, sets shutter speed, ISO and f-number,
// captures, downloads, lists and deletes. Then a raw client sends it
// garbage: the camera drops that client and serves the next one.
#include "hardware/sim/ptpip_camera.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "absl/time/clock.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"
#include "hardware/sim/ptpip_packets.h"
#include "hardware/sim/sim_world.h"
#include "processing/io/exif.h"
#include "tests/support/subprocess.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

constexpr char kGphoto2[] = "/usr/bin/gphoto2";

Scene TestScene() {
  Scene scene = testing::SmallBundledScene("lab-lamp");
  scene.timing.scale = 0;  // no modelled waits
  return scene;
}

class PtpIpCameraTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(std::filesystem::exists(kGphoto2))
        << kGphoto2 << " is missing: deploy/setup-deps.sh installs gphoto2";
    absl::StatusOr<std::unique_ptr<PtpIpCamera>> camera =
        PtpIpCamera::Start(world_, {});
    ASSERT_TRUE(camera.ok()) << camera.status();
    camera_ = *std::move(camera);
  }

  // gphoto2 ARGS against the camera; its output (stdout and stderr).
  std::string Gphoto2(std::vector<std::string> args, int* exit_code) {
    std::vector<std::string> argv = {kGphoto2, "--port",
                                     camera_->gphoto2_port(), "--camera",
                                     PtpIpCamera::kGphoto2Model};
    argv.insert(argv.end(), args.begin(), args.end());
    absl::StatusOr<process::CommandResult> result =
        hdrstereo::testing::RunCommand(argv, absl::Seconds(60));
    EXPECT_TRUE(result.ok()) << result.status();
    if (!result.ok()) return "";
    *exit_code = result->exit_code;
    return result->out + result->err;
  }
  std::string Gphoto2Ok(std::vector<std::string> args) {
    int exit_code = -1;
    std::string out = Gphoto2(args, &exit_code);
    EXPECT_EQ(exit_code, 0) << out;
    return out;
  }

  SimWorld world_{TestScene()};
  std::unique_ptr<PtpIpCamera> camera_;
  hdrstereo::testing::TempDir dir_;
};

TEST_F(PtpIpCameraTest, Gphoto2SummaryNamesTheCameraItsStorageAndSettings) {
  const std::string out = Gphoto2Ok({"--summary"});
  EXPECT_THAT(out, HasSubstr("Model: hdrstereo simulated camera (lab-lamp)"));
  EXPECT_THAT(
      out, HasSubstr(absl::StrCat("Serial Number: sim-", world_.scene().seed)));
  EXPECT_THAT(out, HasSubstr("Capture Formats: PNG"));
  EXPECT_THAT(out, HasSubstr("Generic Image Capture"));
  EXPECT_THAT(out, HasSubstr("Storage Type: Builtin RAM"));
  EXPECT_THAT(out, HasSubstr("Battery Level(0x5001):(read only)"));
  EXPECT_THAT(out, HasSubstr("Exposure Time(0x500d):(readwrite)"));
  EXPECT_THAT(out, HasSubstr("ISO 100"));
  EXPECT_EQ(camera_->connections(), 1);
}

TEST_F(PtpIpCameraTest, Gphoto2ListsAndSetsShutterSpeedIsoAndFNumber) {
  const std::string all = Gphoto2Ok({"--list-all-config"});
  EXPECT_THAT(all, HasSubstr("/main/capturesettings/shutterspeed"));
  EXPECT_THAT(all, HasSubstr("/main/imgsettings/iso"));
  EXPECT_THAT(all, HasSubstr("/main/capturesettings/f-number"));
  EXPECT_THAT(all, HasSubstr("Current: 0.0080s"));  // 1/125 s at start
  EXPECT_THAT(all, HasSubstr("Current: 100%"));     // the battery

  Gphoto2Ok({"--set-config", "shutterspeed=0.0250s", "--set-config", "iso=400",
             "--set-config", "f-number=f/5.6"});
  EXPECT_THAT(Gphoto2Ok({"--get-config", "shutterspeed"}),
              HasSubstr("Current: 0.0250s"));
  EXPECT_THAT(Gphoto2Ok({"--get-config", "iso"}), HasSubstr("Current: 400"));
  EXPECT_THAT(Gphoto2Ok({"--get-config", "f-number"}),
              HasSubstr("Current: f/5.6"));

  // A value the camera does not offer is refused by the camera (gphoto2
  // says so, though it exits 0), and the setting stays.
  int exit_code = -1;
  const std::string refused =
      Gphoto2({"--set-config-value", "/main/other/500f=123"}, &exit_code);
  EXPECT_THAT(refused, HasSubstr("was not set (0x201c: PTP Invalid Device "
                                 "Prop Value)"));
  EXPECT_THAT(Gphoto2Ok({"--get-config", "iso"}), HasSubstr("Current: 400"));
}

TEST_F(PtpIpCameraTest, Gphoto2CapturesTheWorldAtTheExposureItSet) {
  Gphoto2Ok({"--set-config", "shutterspeed=0.0250s", "--set-config", "iso=400",
             "--set-config", "f-number=f/5.6"});
  const std::string file = (dir_.path() / "frame.%C").string();
  const std::string out =
      Gphoto2Ok({"--capture-image-and-download", "--filename", file});
  EXPECT_THAT(out, HasSubstr("/store_00010001/SIM_0001.PNG"));
  // gphoto2 deletes the file from the camera after downloading it.
  EXPECT_EQ(camera_->stored_files(), 0);

  // %C is the camera's suffix as it names the file.
  std::ifstream in(dir_.path() / "frame.PNG", std::ios::binary);
  ASSERT_TRUE(in.good()) << out;
  std::stringstream bytes;
  bytes << in.rdbuf();
  const io::ExifInfo exif = io::ParseExifFromFile(bytes.str());
  ASSERT_TRUE(exif.exposure_s.has_value());
  EXPECT_DOUBLE_EQ(*exif.exposure_s, 0.025);
  EXPECT_EQ(exif.iso, 400);
  EXPECT_DOUBLE_EQ(exif.aperture.value_or(0), 5.6);

  // Pixel for pixel the frame the simulated camera takes with the same
  // settings (the first capture of an identical world: the same noise).
  SimWorld twin(TestScene());
  absl::StatusOr<SimCapture> direct = twin.Capture(
      {.exposure_s = 0.025, .iso = 400, .aperture_f = 5.6}, ImageFormat::kPng);
  ASSERT_TRUE(direct.ok()) << direct.status();
  const std::string& got = bytes.str();
  const cv::Mat frame =
      cv::imdecode(cv::Mat(1, static_cast<int>(got.size()), CV_8U,
                           const_cast<char*>(got.data())),
                   cv::IMREAD_UNCHANGED);
  ASSERT_EQ(frame.size(), direct->image.size());
  EXPECT_EQ(cv::norm(frame, direct->image, cv::NORM_INF), 0);
}

TEST_F(PtpIpCameraTest, Gphoto2ListsAndDeletesTheFilesOnTheCamera) {
  Gphoto2Ok({"--capture-image", "--capture-image"});
  EXPECT_EQ(camera_->stored_files(), 2);
  const std::string listed = Gphoto2Ok({"--list-files"});
  EXPECT_THAT(listed, HasSubstr("SIM_0001.PNG"));
  EXPECT_THAT(listed, HasSubstr("SIM_0002.PNG"));
  EXPECT_THAT(listed, HasSubstr("image/png"));
  Gphoto2Ok({"--delete-all-files", "--recurse"});
  EXPECT_EQ(camera_->stored_files(), 0);
  EXPECT_THAT(Gphoto2Ok({"--list-files"}), Not(HasSubstr("SIM_0001")));
}

// A bare PTP/IP client for the bad-input tests.
class RawClient {
 public:
  explicit RawClient(int port) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in sa{};
    sa.sin_family = AF_INET;
    sa.sin_port = htons(static_cast<uint16_t>(port));
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ =
        connect(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof(sa)) == 0;
  }
  ~RawClient() { close(fd_); }
  bool connected() const { return connected_; }
  void Send(const std::string& bytes) {
    ASSERT_EQ(send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL),
              static_cast<ssize_t>(bytes.size()));
  }
  // The next packet, or nullopt when the camera closed the connection or
  // 5 s passed.
  std::optional<ptpip::Packet> Read() {
    const absl::Time deadline = absl::Now() + absl::Seconds(5);
    while (absl::Now() < deadline) {
      absl::StatusOr<std::optional<ptpip::Packet>> next = reader_.Next();
      if (!next.ok()) return std::nullopt;
      if (next->has_value()) return std::move(**next);
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char buffer[4096];
      const ssize_t n = recv(fd_, buffer, sizeof(buffer), 0);
      if (n <= 0) return std::nullopt;
      reader_.Append(absl::string_view(buffer, static_cast<size_t>(n)));
    }
    return std::nullopt;
  }
  // Sends what it can: the camera may have closed the connection already.
  void SendIfOpen(const std::string& bytes) {
    (void)send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  }
  // Reads what the camera answered within 20 ms, and forgets it.
  void Drain() {
    char buffer[4096];
    pollfd p{fd_, POLLIN, 0};
    while (poll(&p, 1, 20) > 0 && recv(fd_, buffer, sizeof(buffer), 0) > 0) {
    }
  }
  // True when the camera closed the connection within 5 s.
  bool Closed() {
    const absl::Time deadline = absl::Now() + absl::Seconds(5);
    while (absl::Now() < deadline) {
      pollfd p{fd_, POLLIN, 0};
      if (poll(&p, 1, 100) <= 0) continue;
      char buffer[4096];
      if (recv(fd_, buffer, sizeof(buffer), 0) <= 0) return true;
    }
    return false;
  }

 private:
  int fd_ = -1;
  bool connected_ = false;
  ptpip::PacketReader reader_{1 << 24};
};

std::string Le32(uint32_t v) {
  std::string out;
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>(v >> (8 * i)));
  return out;
}

// The little-endian number of `width` bytes at `at` of `bytes`.
uint32_t LoadLe(absl::string_view bytes, size_t at, int width) {
  uint32_t v = 0;
  for (int i = width - 1; i >= 0; --i) {
    v = v << 8 | static_cast<uint8_t>(bytes[at + static_cast<size_t>(i)]);
  }
  return v;
}

std::string Framed(uint32_t type, const std::string& body) {
  return Le32(static_cast<uint32_t>(8 + body.size())) + Le32(type) + body;
}

std::string Request(uint16_t code, uint32_t transaction,
                    std::vector<uint32_t> params = {},
                    uint32_t data_phase = ptpip::kNoDataOrToClient) {
  std::string body = Le32(data_phase);
  body +=
      std::string{static_cast<char>(code & 0xFF), static_cast<char>(code >> 8)};
  body += Le32(transaction);
  for (uint32_t p : params) body += Le32(p);
  return Framed(ptpip::kOperationRequest, body);
}

// The init handshake and OpenSession, as libgphoto2 does them; the
// connection number the camera gave goes to `connection` when asked.
void OpenSession(RawClient& client, uint32_t* connection = nullptr) {
  std::string init(16, '\x42');
  init += std::string("t\0\0\0", 4);  // "t" and the zero, UCS-2
  init += Le32(0x00010000);
  client.Send(Framed(ptpip::kInitCommandRequest, init));
  std::optional<ptpip::Packet> ack = client.Read();
  ASSERT_TRUE(ack.has_value());
  ASSERT_EQ(ack->type, ptpip::kInitCommandAck);
  ASSERT_GE(ack->body.size(), 4u);
  if (connection != nullptr) *connection = LoadLe(ack->body, 0, 4);
  client.Send(Request(ptpip::op::kOpenSession, 0, {1}));
  std::optional<ptpip::Packet> response = client.Read();
  ASSERT_TRUE(response.has_value());
  ASSERT_EQ(response->type, ptpip::kOperationResponse);
  EXPECT_EQ(response->body.substr(0, 2), std::string("\x01\x20", 2));
}

uint16_t ResponseCode(const std::optional<ptpip::Packet>& packet) {
  if (!packet.has_value() || packet->type != ptpip::kOperationResponse ||
      packet->body.size() < 2) {
    return 0;
  }
  return static_cast<uint16_t>(LoadLe(packet->body, 0, 2));
}

TEST_F(PtpIpCameraTest, AnAbsurdPacketLengthDropsThatClientOnly) {
  RawClient bad(camera_->port());
  ASSERT_TRUE(bad.connected());
  OpenSession(bad);
  bad.Send(Le32(0xFFFFFFF0) + Le32(ptpip::kOperationRequest));
  EXPECT_TRUE(bad.Closed());
  EXPECT_THAT(camera_->last_event(), HasSubstr("declares 4294967280 bytes"));
  // The next client is served.
  EXPECT_THAT(Gphoto2Ok({"--summary"}), HasSubstr("hdrstereo simulated"));
}

TEST_F(PtpIpCameraTest, AFourGigabyteDataPhaseIsRefusedBeforeItArrives) {
  RawClient client(camera_->port());
  ASSERT_TRUE(client.connected());
  OpenSession(client);
  client.Send(Request(ptpip::op::kSetDevicePropValue, 1,
                      {ptpip::prop::kExposureIndex}, ptpip::kFromClient));
  client.Send(Framed(ptpip::kStartData, Le32(1) + Le32(0) + Le32(1)));
  EXPECT_TRUE(client.Closed());
  EXPECT_THAT(camera_->last_event(),
              HasSubstr("announces 4294967296 bytes of data"));
}

TEST_F(PtpIpCameraTest, UnknownOperationsAndStaleTransactionsAreAnswered) {
  RawClient client(camera_->port());
  ASSERT_TRUE(client.connected());
  OpenSession(client);
  client.Send(Request(0x9999, 1));
  EXPECT_EQ(ResponseCode(client.Read()), ptpip::rc::kOperationNotSupported);
  client.Send(Request(ptpip::op::kGetStorageInfo, 1, {0x00010001}));
  EXPECT_EQ(ResponseCode(client.Read()), ptpip::rc::kInvalidTransactionId);
  client.Send(Request(ptpip::op::kGetObject, 2, {777}));
  EXPECT_EQ(ResponseCode(client.Read()), ptpip::rc::kInvalidObjectHandle);
  // A request that announces data it does not send gets no answer until
  // its data; a packet of another kind instead ends the connection.
  client.Send(Request(ptpip::op::kSetDevicePropValue, 3,
                      {ptpip::prop::kExposureIndex}, ptpip::kFromClient));
  client.Send(Request(ptpip::op::kGetStorageIds, 4));
  EXPECT_TRUE(client.Closed());
  EXPECT_THAT(camera_->last_event(),
              HasSubstr("where the request's StartData"));
}

// A client may trigger again as soon as it reads CaptureComplete (the
// gphoto2 driver does, after downloading the file). The camera must take
// that trigger: a DeviceBusy leaves libgphoto2 waiting for ever, which CI
// once saw as a stuck capture when the camera released its trigger only
// after its last event. 200 back-to-back triggers, each read up to its
// CaptureComplete and no further, catch that window when the machine is
// busy: with four busy loops on two cores the old order failed within four
// triggers in 3 runs of 3 (idle, in none of 3).
TEST_F(PtpIpCameraTest, TheNextTriggerIsTakenAsSoonAsCaptureCompleteIsRead) {
  RawClient commands(camera_->port());
  ASSERT_TRUE(commands.connected());
  uint32_t connection = 0;
  ASSERT_NO_FATAL_FAILURE(OpenSession(commands, &connection));
  RawClient events(camera_->port());
  ASSERT_TRUE(events.connected());
  events.Send(Framed(ptpip::kInitEventRequest, Le32(connection)));
  std::optional<ptpip::Packet> ack = events.Read();
  ASSERT_TRUE(ack.has_value());
  ASSERT_EQ(ack->type, ptpip::kInitEventAck);
  // An event's code and transaction (its body starts with both).
  const auto read_event = [&events]() -> std::pair<uint16_t, uint32_t> {
    std::optional<ptpip::Packet> event = events.Read();
    if (!event.has_value() || event->type != ptpip::kEvent ||
        event->body.size() < 6) {
      return {0, 0};
    }
    return {static_cast<uint16_t>(LoadLe(event->body, 0, 2)),
            LoadLe(event->body, 2, 4)};
  };
  for (uint32_t transaction = 1; transaction <= 200; ++transaction) {
    commands.Send(Request(ptpip::op::kInitiateCapture, transaction, {0, 0}));
    ASSERT_EQ(ResponseCode(commands.Read()), ptpip::rc::kOk)
        << "trigger " << transaction;
    // Its own events, in order, before the next trigger's.
    EXPECT_EQ(read_event(),
              std::make_pair(ptpip::event::kObjectAdded, transaction));
    ASSERT_EQ(read_event(),
              std::make_pair(ptpip::event::kCaptureComplete, transaction))
        << "trigger " << transaction;
  }
}

TEST_F(PtpIpCameraTest, GarbageInsteadOfAHandshakeIsClosed) {
  RawClient client(camera_->port());
  ASSERT_TRUE(client.connected());
  client.Send("GET / HTTP/1.1\r\nHost: camera\r\n\r\n");
  EXPECT_TRUE(client.Closed());
  EXPECT_EQ(camera_->connections(), 0);
  EXPECT_THAT(Gphoto2Ok({"--summary"}), HasSubstr("hdrstereo simulated"));
}

// A bounded random test of the camera's packet handling (the parsers are
// also fuzzed: tests/fuzz/ptpip_packet_fuzzer.cc): 150 clients, seeded,
// each sending up to 8 packets of random type and body, half of them after
// a proper handshake and OpenSession, half of those with well-formed
// operation requests of random codes, parameters and data phases. No
// client may stop the camera: afterwards gphoto2 still captures.
TEST_F(PtpIpCameraTest, RandomPacketsNeverStopTheCamera) {
  std::mt19937 random(20261206);
  const auto uniform = [&](int lo, int hi) {
    return std::uniform_int_distribution<int>(lo, hi)(random);
  };
  for (int round = 0; round < 150; ++round) {
    RawClient client(camera_->port());
    ASSERT_TRUE(client.connected());
    const bool handshake = uniform(0, 1) == 1;
    if (handshake) OpenSession(client);
    const int packets = uniform(1, 8);
    for (int i = 0; i < packets; ++i) {
      std::string bytes;
      if (handshake && uniform(0, 1) == 1) {
        std::vector<uint32_t> params(static_cast<size_t>(uniform(0, 5)));
        for (uint32_t& p : params) p = static_cast<uint32_t>(random());
        bytes = Request(static_cast<uint16_t>(0x1000 + uniform(0, 0x30)),
                        static_cast<uint32_t>(uniform(0, 20)), params,
                        static_cast<uint32_t>(uniform(0, 3)));
      } else {
        std::string body(static_cast<size_t>(uniform(0, 64)), '\0');
        for (char& c : body) c = static_cast<char>(uniform(0, 255));
        bytes = Framed(static_cast<uint32_t>(uniform(0, 15)), body);
      }
      client.SendIfOpen(bytes);
    }
    client.Drain();
  }
  const std::string file = (dir_.path() / "after.%C").string();
  EXPECT_THAT(Gphoto2Ok({"--capture-image-and-download", "--filename", file}),
              HasSubstr("Saving file as"));
  EXPECT_TRUE(std::filesystem::exists(dir_.path() / "after.PNG"));
}

}  // namespace
}  // namespace hdrstereo::sim
