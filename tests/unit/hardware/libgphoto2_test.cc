// SPDX-License-Identifier: GPL-3.0-or-later
//
// The real libgphoto2 paths that need no camera: autodetection that finds
// nothing, and libgphoto2's "Directory Browse" camera driver, which serves a
// folder ("disk:<folder>" port) as a camera's storage.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/gphoto2/libgphoto2_api.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

// Under LeakSanitizer: libgphoto2's port drivers (iolibs, dlopen'ed by
// gp_port_info_list_load) leak a few bytes per load, in the library itself
// (reproduced with a five-line C program). Suppress leaks whose allocation
// stack passes through libgphoto2_port, which needs full (slow) unwinding
// because the library has no frame pointers. No effect without sanitizers.
extern "C" const char* __asan_default_options() {
  return "fast_unwind_on_malloc=0";
}
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libgphoto2_port.so\n";
}

namespace hdrstereo::gphoto2 {
namespace {

using ::hdrstereo::testing::StatusIs;

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

void WriteFile(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

TEST(Libgphoto2Test, OpenWithoutACameraSaysNoCameraFound) {
  std::vector<DetectedCamera> detected;
  ASSERT_GE(NewLibgphoto2Api()->Autodetect(&detected), 0);
  if (!detected.empty()) {
    GTEST_SKIP() << "a camera is connected: " << detected[0].model << " on "
                 << detected[0].port;
  }
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::Open(Gphoto2Options());
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("no camera found"));
}

TEST(Libgphoto2Test, AnUnknownModelIsNotFound) {
  Gphoto2Options options;
  options.model = "Hdrstereo Imaginary Camera 9000";
  options.port = "usb:";
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::Open(options);
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("no such camera model"));

  // Without a port too, whether or not a camera is connected: the model is
  // looked up in libgphoto2's abilities list before any autodetect.
  options.port.clear();
  camera = Gphoto2Camera::Open(options);
  EXPECT_EQ(camera.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(std::string(camera.status().message()),
              HasSubstr("look up camera model \"Hdrstereo Imaginary Camera "
                        "9000\": libgphoto2 knows no such camera model"));
}

TEST(Libgphoto2Test, DirectoryBrowseListsDownloadsAndDeletesFiles) {
  testing::TempDir dir;
  WriteFile(dir / "IMG_0001.JPG", std::string("\xff\xd8\xff\xe0 jpeg", 9));
  WriteFile(dir / "IMG_0001.CR2", "II*\0 raw");
  Gphoto2Options options;
  options.model = "Directory Browse";
  options.port = "disk:" + dir.path().string();
  absl::StatusOr<std::unique_ptr<Gphoto2Camera>> camera =
      Gphoto2Camera::Open(options);
  ASSERT_TRUE(camera.ok()) << camera.status();
  Gphoto2Camera& browse = **camera;

  absl::StatusOr<hardware::CameraInfo> info = browse.Info();
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->model, "Directory Browse");
  EXPECT_EQ(info->port, options.port);

  absl::StatusOr<std::vector<std::string>> names = browse.ListFiles("/");
  ASSERT_TRUE(names.ok()) << names.status();
  EXPECT_THAT(*names, UnorderedElementsAre("IMG_0001.JPG", "IMG_0001.CR2"));

  absl::StatusOr<hardware::Frame> jpeg = browse.Download("/", "IMG_0001.JPG");
  ASSERT_TRUE(jpeg.ok()) << jpeg.status();
  EXPECT_EQ(jpeg->bytes, std::string("\xff\xd8\xff\xe0 jpeg", 9));
  EXPECT_EQ(jpeg->format, hardware::ImageFormat::kJpeg);
  EXPECT_EQ(jpeg->extension, "jpg");

  absl::StatusOr<hardware::Frame> missing = browse.Download("/", "NONE.JPG");
  EXPECT_THAT(missing, StatusIs(absl::StatusCode::kNotFound,
                                HasSubstr("download /NONE.JPG")));

  ASSERT_TRUE(browse.DeleteFile("/", "IMG_0001.CR2").ok());
  EXPECT_FALSE(std::filesystem::exists(dir / "IMG_0001.CR2"));
  EXPECT_TRUE(std::filesystem::exists(dir / "IMG_0001.JPG"));

  // A folder is no camera: no settings, no capture, each said clearly.
  EXPECT_EQ(browse.Settings().status().code(),
            absl::StatusCode::kUnimplemented);
  absl::StatusOr<hardware::Frame> frame = browse.Capture();
  EXPECT_EQ(frame.status().code(), absl::StatusCode::kUnimplemented);
  EXPECT_THAT(std::string(frame.status().message()), HasSubstr("capture"));
}

}  // namespace
}  // namespace hdrstereo::gphoto2
