// SPDX-License-Identifier: GPL-3.0-or-later
//
// Captures laid out by others, on synthetic frames with a known truth: a
// camera whose pixels each see 3.1 projector columns (2.9 rows) through a
// blur 1.5 times that wide, so that the finest stripes average out as on a real
// capture whose projector out-resolves the camera; codes gray(x + offset);
// frames written in another lab's order and read back through a layout file.
#include "processing/structured_light/frame_layout.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "processing/io/hdr_formats.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/disparity.h"
#include "processing/structured_light/gray_code.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::structured_light {
namespace {

using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr int kBits = 10;  // 1000 columns and 700 rows, codes centred
constexpr int kColumnOffset = 12, kRowOffset = 162;
const cv::Size kProjector(1000, 700);
const cv::Size kCamera(240, 160);

// Projector column and row at the centre of camera pixel (x, y).
double TrueColumn(int x) { return 100 + 3.1 * x; }
double TrueRow(int y) { return 80 + 2.9 * y; }

// The camera's view of one code plane: each pixel averages the stripes
// over 1.5 times its pitch (lens blur; 16 samples), grey 20 .. 200.
cv::Mat CameraFrame(bool columns, int bit, bool inverse) {
  const int offset = columns ? kColumnOffset : kRowOffset;
  cv::Mat out(kCamera, CV_8UC1);
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      double lit = 0;
      for (int s = 0; s < 16; ++s) {
        const double t = 1.5 * ((s + 0.5) / 16 - 0.5);
        const double p =
            columns ? TrueColumn(x) + 3.1 * t : TrueRow(y) + 2.9 * t;
        const int code = ToGray(static_cast<int>(std::floor(p)) + offset);
        lit += ((code >> (kBits - 1 - bit)) & 1) != inverse;
      }
      out.at<uint8_t>(y, x) = static_cast<uint8_t>(20 + 180 * lit / 16);
    }
  }
  return out;
}

// Our own order: column planes (each with its inverse), row planes, white,
// black.
ViewFrames SyntheticView() {
  ViewFrames view;
  view.projector_size = kProjector;
  view.column_bits = view.row_bits = kBits;
  view.column_offset = kColumnOffset;
  view.row_offset = kRowOffset;
  ExposureFrames e;
  for (bool columns : {true, false}) {
    for (int bit = 0; bit < kBits; ++bit) {
      e.frames.push_back(CameraFrame(columns, bit, false));
      e.frames.push_back(CameraFrame(columns, bit, true));
    }
  }
  e.frames.push_back(cv::Mat(kCamera, CV_8UC1, cv::Scalar(200)));
  e.frames.push_back(cv::Mat(kCamera, CV_8UC1, cv::Scalar(20)));
  view.exposures.push_back(std::move(e));
  return view;
}

TEST(CoarseDecodeTest, EveryBitRequiredDecodesNothingWhenFineStripesBlur) {
  absl::StatusOr<DecodedView> all = Decode(SyntheticView());
  ASSERT_THAT(all, ::hdrstereo::testing::IsOk());
  EXPECT_EQ(all->valid_pixels, 0);
}

// Each pixel reads its code down to its last usable bit and stands for the
// middle of what those bits allow (or for the stripe edge it straddles):
// within half that range plus half the blurred footprint of the truth.
TEST(CoarseDecodeTest, ReadsTheUsableBitsAndStandsForTheirRange) {
  DecodeOptions options;
  options.min_bits = 6;
  ASSERT_OK_AND_ASSIGN(DecodedView d, Decode(SyntheticView(), options));
  EXPECT_GE(d.valid_pixels, kCamera.area() * 8 / 10);  // measured 85 %
  EXPECT_EQ(d.column_code_bits, kBits);
  int worst_bits = 0;
  double worst_excess = 0;
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      const int c = d.column.at<int32_t>(y, x);
      if (c < 0) continue;
      const int bits = d.column_bits.at<uint8_t>(y, x);
      EXPECT_GE(bits, 6);
      worst_bits = std::max(worst_bits, bits);
      const double half = 0.5 * (1 << (kBits - bits));
      worst_excess = std::max(worst_excess,
                              std::abs(c - TrueColumn(x)) - half - 2.33 - 0.5);
    }
  }
  // Stripes 2 columns wide cannot be seen through 4.65.
  EXPECT_LE(worst_bits, kBits - 1);
  EXPECT_LE(worst_excess, 0.0);

  // The sub-pixel codes interpolate the coarse codes back to the truth.
  const SubpixelCodes codes = ComputeSubpixelCodes(d);
  std::vector<double> err;
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      const float u = codes.column.at<float>(y, x);
      if (!std::isnan(u)) err.push_back(std::abs(u - TrueColumn(x)));
    }
  }
  ASSERT_GT(err.size(), static_cast<size_t>(kCamera.area() * 8 / 10));
  std::nth_element(err.begin(), err.begin() + err.size() / 2, err.end());
  EXPECT_LE(err[err.size() / 2], 1.0) << "median |continuous - true| column";
}

constexpr char kLayout[] = R"({
  "format": "hdrstereo-sl-layout-1",
  "projector": {"width": 1000, "height": 700},
  "files": "cam_{view}/img{frame:03}.png",
  "views": ["a"],
  "white": 0,
  "black": 41,
  "columns": {"bits": 10, "first_frame": 1, "bit_order": "lsb-first",
              "inverse": "blocked", "code_offset": 12},
  "rows": {"bits": 10, "first_frame": 21, "code_offset": 162},
  "min_bits": 6
})";

// Another lab's order (columns LSB first, all normals then all inverses;
// rows MSB first interleaved; white first, black last) written to files and
// read back through the layout gives exactly the frames in our order.
TEST(FrameLayoutTest, LoadsFramesInTheLayoutsOrder) {
  ASSERT_OK_AND_ASSIGN(FrameLayout layout, ParseFrameLayout(kLayout));
  ASSERT_OK_AND_ASSIGN(const std::string name, layout.FileName(7, "a"));
  EXPECT_EQ(name, "cam_a/img007.png");
  EXPECT_EQ(layout.columns.Frame(0, false), 10);  // MSB, LSB first
  EXPECT_EQ(layout.columns.Frame(9, false), 1);
  EXPECT_EQ(layout.columns.Frame(9, true), 11);
  EXPECT_EQ(layout.rows.Frame(0, true), 22);
  const ViewFrames ours = SyntheticView();
  const std::vector<cv::Mat>& f = ours.exposures[0].frames;
  ::hdrstereo::testing::TempDir dir;
  std::filesystem::create_directories(dir / "cam_a");
  auto write = [&](int frame, const cv::Mat& image) {
    ASSERT_OK_AND_ASSIGN(const std::string name, layout.FileName(frame, "a"));
    ASSERT_OK(io::WritePng(dir / name, image));
  };
  for (int bit = 0; bit < kBits; ++bit) {
    write(layout.columns.Frame(bit, false), f[2 * bit]);
    write(layout.columns.Frame(bit, true), f[2 * bit + 1]);
    write(layout.rows.Frame(bit, false), f[2 * kBits + 2 * bit]);
    write(layout.rows.Frame(bit, true), f[2 * kBits + 2 * bit + 1]);
  }
  write(layout.white, f[4 * kBits]);
  write(layout.black, f[4 * kBits + 1]);
  ASSERT_OK_AND_ASSIGN(ViewFrames loaded,
                       LoadLayoutView(layout, dir.path(), "a"));
  EXPECT_EQ(loaded.projector_size, kProjector);
  EXPECT_EQ(loaded.column_offset, kColumnOffset);
  EXPECT_EQ(loaded.row_offset, kRowOffset);
  ASSERT_EQ(loaded.exposures[0].frames.size(), f.size());
  for (size_t i = 0; i < f.size(); ++i) {
    EXPECT_EQ(cv::norm(loaded.exposures[0].frames[i], f[i], cv::NORM_INF), 0)
        << "frame " << i;
  }

  // A missing file is named; an unknown view is refused.
  std::filesystem::remove(dir / "cam_a" / "img013.png");
  EXPECT_THAT(LoadLayoutView(layout, dir.path(), "a"),
              StatusIs(absl::StatusCode::kNotFound, HasSubstr("img013.png")));
  EXPECT_THAT(LoadLayoutView(layout, dir.path(), "b"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the layout has no view \"b\"")));
}

TEST(FrameLayoutTest, BadLayoutsNameTheField) {
  auto parse = [](const std::string& text) { return ParseFrameLayout(text); };
  EXPECT_THAT(parse("{"), StatusIs(absl::StatusCode::kInvalidArgument,
                                   HasSubstr("is not JSON")));
  EXPECT_THAT(parse(R"({"format": "x"})"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("format: must be \"hdrstereo-sl-layout-1\"")));
  std::string text = kLayout;
  auto with = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return parse(t);
  };
  EXPECT_THAT(with("\"bits\": 10, \"first_frame\": 1",
                   "\"bits\": 9, \"first_frame\": 1"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("columns.bits: 9 bits cannot code 1000 "
                                 "projector columns with code offset 12")));
  EXPECT_THAT(with("\"black\": 41", "\"black\": 0"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("black: is the same frame as white")));
  EXPECT_THAT(with("\"first_frame\": 21", "\"first_frame\": 20"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("is already used by another pattern")));
  EXPECT_THAT(with("\"lsb-first\"", "\"backwards\""),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("columns.bit_order: must be one of")));
  EXPECT_THAT(with("\"views\": [\"a\"]", "\"views\": []"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("views: missing")));
  EXPECT_THAT(with("\"min_bits\": 6", "\"min_bits\": 12"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("min_bits: is more than the bits")));
}

// kLayout with `from` replaced by `to`, parsed.
absl::StatusOr<FrameLayout> ParseWith(const std::string& from,
                                      const std::string& to) {
  std::string text = kLayout;
  text.replace(text.find(from), from.size(), to);
  return ParseFrameLayout(text);
}

constexpr char kFiles[] = "\"cam_{view}/img{frame:03}.png\"";

// The review's layout: 400 valid-looking bytes whose template asked for
// two-billion-digit frame numbers (9.8 GB, 53 s and a 2 GB message). It is
// refused naming the key, the value and the limit, in a short message, and
// FileName refuses it even on a layout that was never parsed.
TEST(FrameLayoutTest, ATwoBillionDigitFrameNumberIsRefused) {
  const absl::StatusOr<FrameLayout> layout =
      ParseWith(kFiles, "\"x{frame:2000000000}.png\"");
  EXPECT_THAT(layout, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("structured-light layout: files: "
                                         "\"x{frame:2000000000}.png\" pads "
                                         "frame numbers to \"2000000000\" "
                                         "digits; the limit is [1, 9]")));
  EXPECT_LT(layout.status().message().size(), 200u);

  FrameLayout unparsed;
  unparsed.files = "x{frame:2000000000}.png";
  EXPECT_THAT(unparsed.FileName(1, "left"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the limit is [1, 9]")));
  unparsed.files = "x{frame:99999999999999999999999}.png";  // not an int64
  EXPECT_THAT(unparsed.FileName(1, "left"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("the limit is [1, 9]")));
  unparsed.files = "x{frame:9}.png";
  ASSERT_OK_AND_ASSIGN(const std::string name, unparsed.FileName(12, "left"));
  EXPECT_EQ(name, "x000000012.png");
  EXPECT_THAT(unparsed.FileName(kMaxLayoutFrames + 1, "left"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("frame: 67 is outside [0, 66]")));
  EXPECT_THAT(unparsed.FileName(-1, "left"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("frame: -1 is outside [0, 66]")));
}

TEST(FrameLayoutTest, FilesStayInsideTheCaptureFolder) {
  const std::pair<const char*, const char*> bad[] = {
      {"\"../{frame}.png\"",
       "files: \"../{frame}.png\": path \"../0.png\" has a \"..\" component"},
      {"\"{view}/../../{frame}.png\"",
       "path \"a/../../0.png\" has a \"..\" component"},
      {"\"/data/{view}{frame}.png\"", "path \"/data/a0.png\" is absolute"},
      {"\"{view}//{frame}.png\"", "path \"a//0.png\" has an empty component"},
  };
  for (const auto& [files, message] : bad) {
    EXPECT_THAT(
        ParseWith(kFiles, files),
        StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << files;
  }
}

// An unpadded {frame} gains a digit from frame 10 on: a name of exactly
// PATH_MAX bytes at frame 0 is too long at frame 10, so the names of the
// last frame the layout uses are checked when it is parsed, not only when
// that frame is loaded.
TEST(FrameLayoutTest, TheNamesOfTheLastFrameAreCheckedWhenParsed) {
  const std::string view(46, 'a');
  std::string files;
  for (int i = 0; i < 89; ++i) files += "{view}";
  files += "{frame}{frame}";
  ASSERT_EQ(files.size(), 548u);
  FrameLayout unparsed;
  unparsed.files = files;
  ASSERT_OK_AND_ASSIGN(const std::string first, unparsed.FileName(0, view));
  EXPECT_EQ(first.size(), 4096u);
  EXPECT_THAT(unparsed.FileName(10, view),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("(4098 bytes) is longer than the limit of "
                                 "4096 bytes")));

  std::string text = kLayout;
  text.replace(text.find("[\"a\"]"), 5, "[\"" + view + "\"]");
  text.replace(text.find(kFiles), std::strlen(kFiles), "\"" + files + "\"");
  const absl::StatusOr<FrameLayout> layout = ParseFrameLayout(text);
  EXPECT_THAT(layout, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("structured-light layout: files: ")));
  EXPECT_THAT(layout, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("(4098 bytes) is longer than the "
                                         "limit of 4096 bytes")));
  EXPECT_LT(layout.status().message().size(), 400u);
}

TEST(FrameLayoutTest, TheTemplateHasOnlyItsPlaceholders) {
  const std::pair<const char*, const char*> bad[] = {
      {"\"img{frame.png\"",
       "files: \"img{frame.png\" has a '{' without its '}'"},
      {"\"img}{frame}.png\"",
       "files: \"img}{frame}.png\" has a '}' without its '{'"},
      {"\"{frame}{id}.png\"",
       "has the placeholder \"{id}\"; allowed are {frame}, {frame:N} and "
       "{view}"},
      {"\"{frame:{view}}.png\"", "has the placeholder \"{frame:{view}\""},
      {"\"{frame:0}.png\"", "pads frame numbers to \"0\" digits"},
      {"\"{frame:-2}.png\"", "has the placeholder \"{frame:-2}\""},
      {"\"{view}.png\"", "has no {frame}"},
      {"3", "files: must be a string"},
  };
  for (const auto& [files, message] : bad) {
    EXPECT_THAT(
        ParseWith(kFiles, files),
        StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << files;
  }
  // A long template is refused with a bounded quote.
  const absl::StatusOr<FrameLayout> long_files =
      ParseWith(kFiles, "\"" + std::string(100000, 'x') + "{frame}\"");
  EXPECT_THAT(long_files, StatusIs(absl::StatusCode::kInvalidArgument,
                                   HasSubstr("... (100007 bytes) is longer "
                                             "than the limit of 1024 bytes")));
  EXPECT_LT(long_files.status().message().size(), 250u);
}

TEST(FrameLayoutTest, ViewNamesAreSafeInFileNames) {
  const std::pair<const char*, const char*> bad[] = {
      {"[\"a/b\"]",
       "views: \"a/b\" is not a view name (1 to 64 letters, "
       "digits, '-' or '_')"},
      {"[\"..\"]", "views: \"..\" is not a view name"},
      {"[\"\"]", "views: \"\" is not a view name"},
      {"[7]", "views: must be names (strings)"},
      {"[\"a\",\"a\",\"a\",\"a\",\"a\",\"a\",\"a\",\"a\",\"a\",\"a\",\"a\","
       "\"a\",\"a\",\"a\",\"a\",\"a\",\"a\"]",
       "views: 17 views, more than the limit of 16"},
  };
  for (const auto& [views, message] : bad) {
    EXPECT_THAT(
        ParseWith("[\"a\"]", views),
        StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
        << views;
  }
  EXPECT_THAT(ParseWith("[\"a\"]", "[\"" + std::string(65, 'v') + "\"]"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("is not a view name (1 to 64")));
}

// kLayout uses 42 frames (white, black, 2 x 10 bits with inverses for each
// code), numbered 0 to 41.
TEST(FrameLayoutTest, NoFrameIsBeyondTheLayoutsFrameCount) {
  EXPECT_THAT(ParseWith("\"black\": 41", "\"black\": 50"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("black: 50 is beyond the layout's 42 frames "
                                 "(white, black and 40 code planes, numbered "
                                 "from 0 or 1)")));
  EXPECT_THAT(ParseWith("\"first_frame\": 21", "\"first_frame\": 60"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("rows.first_frame: 60 puts bit 0 at frame 60, "
                                 "beyond the layout's 42 frames")));
  EXPECT_THAT(ParseWith("\"first_frame\": 21", "\"first_frame\": 2000000000"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("rows.first_frame: 2000000000 is outside "
                                 "[0, 66]")));
  EXPECT_THAT(
      ParseWith("\"white\": 0", "\"white\": 18446744073709551615"),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("white: ")));
  // Numbered from 1, the last frame is the frame count itself.
  EXPECT_OK(ParseWith("\"white\": 0", "\"white\": 42"));
}

TEST(FrameLayoutTest, TheProjectorIsAtMostWhatADisplayCanBe) {
  EXPECT_THAT(ParseWith("\"width\": 1000", "\"width\": 16385"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("projector.width: 16385 is outside "
                                 "[1, 16384]")));
  EXPECT_THAT(ParseWith("\"height\": 700", "\"height\": -700"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("projector.height: -700 is outside "
                                 "[1, 16384]")));
}

// Refused by the file's size before it is read (a sparse file: no disk
// used), not by the parser's check of the text.
TEST(FrameLayoutTest, AHugeLayoutFileIsRefusedUnread) {
  ::hdrstereo::testing::TempDir dir;
  const std::filesystem::path file = dir / "layout.json";
  { std::ofstream(file) << kLayout; }
  std::filesystem::resize_file(file, 2 << 20);
  EXPECT_THAT(LoadFrameLayout(file),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       file.string() +
                           ": structured-light layout of 2097152 bytes, more "
                           "than the limit of 1048576; not read"));
  EXPECT_THAT(ParseFrameLayout(std::string(2 << 20, ' ')),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       "structured-light layout: 2097152 bytes, more than the "
                       "limit of 1048576"));
}

TEST(FrameLayoutTest, ANotJsonMessageQuotesABoundedPrefix) {
  const absl::StatusOr<FrameLayout> layout =
      ParseFrameLayout("{\"files\": \"" + std::string(100000, 'x'));
  EXPECT_THAT(layout, StatusIs(absl::StatusCode::kInvalidArgument,
                               HasSubstr("structured-light layout is not "
                                         "JSON: ")));
  EXPECT_LT(layout.status().message().size(), 400u);
}

}  // namespace
}  // namespace hdrstereo::structured_light
