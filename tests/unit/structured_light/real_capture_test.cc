// SPDX-License-Identifier: GPL-3.0-or-later
//
// A third-party Gray-code capture (../shared/data/graycode-stereo-zengzhik:
// two 1280x720 cameras, a 3840x2160 projector, 12-bit column and row codes
// with inverses, codes gray(x + 128) and gray(y + 968), MSB first, capture
// NN showing pattern NN) decoded through a layout file written from the
// folder's README. Its finest 3-4 bits are below the cameras' resolution,
// so the decoder must read each pixel's code only down to its last usable
// bit. Scored against the author's own disparity (disparity.npy: the top 9
// bits, x_left - mean x_right, 5x5 median; a rough reference, not ground
// truth).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/structured_light.hpp>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/structured_light/decode.h"
#include "processing/structured_light/disparity.h"
#include "processing/structured_light/frame_layout.h"
#include "tests/support/proc_tool.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::structured_light {
namespace {

namespace fs = std::filesystem;

// The folder README's description as a layout file.
constexpr char kLayout[] = R"({
  "format": "hdrstereo-sl-layout-1",
  "projector": {"width": 3840, "height": 2160},
  "files": "capture/{frame:02}-{view}.png",
  "views": ["left", "right"],
  "white": 1,
  "black": 2,
  "columns": {"bits": 12, "first_frame": 3, "bit_order": "msb-first",
              "inverse": "interleaved", "code_offset": 128},
  "rows": {"bits": 12, "first_frame": 27, "bit_order": "msb-first",
           "inverse": "interleaved", "code_offset": 968},
  "min_bits": 7
})";

fs::path Capture() {
  return fs::path(HDRSTEREO_SHARED_DIR) / "data" / "graycode-stereo-zengzhik";
}

// A little-endian float32 2-D .npy file (format 1.0 or 2.0).
absl::StatusOr<cv::Mat> ReadNpy(const fs::path& path) {
  ASSIGN_OR_RETURN(std::string bytes, io::ReadFileBytes(path));
  if (bytes.size() < 12 || bytes.compare(0, 6, "\x93NUMPY") != 0) {
    return absl::InvalidArgumentError("not a .npy file");
  }
  const int major = bytes[6];
  size_t header_len = 0, start = 0;
  if (major == 1) {
    header_len = static_cast<uint8_t>(bytes[8]) | static_cast<uint8_t>(bytes[9])
                                                      << 8;
    start = 10;
  } else {
    for (int i = 0; i < 4; ++i) {
      header_len |= size_t{static_cast<uint8_t>(bytes[8 + i])} << (8 * i);
    }
    start = 12;
  }
  const std::string header = bytes.substr(start, header_len);
  if (!absl::StrContains(header, "'descr': '<f4'") ||
      !absl::StrContains(header, "'fortran_order': False")) {
    return absl::InvalidArgumentError("need little-endian float32, C order");
  }
  const size_t shape = header.find("'shape': (");
  int rows = 0, cols = 0;
  if (shape == std::string::npos ||
      std::sscanf(header.c_str() + shape, "'shape': (%d, %d)", &rows, &cols) !=
          2) {
    return absl::InvalidArgumentError("need a 2-D shape");
  }
  const size_t data = start + header_len;
  if (bytes.size() < data + size_t{4} * rows * cols) {
    return absl::InvalidArgumentError("truncated .npy");
  }
  cv::Mat out(rows, cols, CV_32FC1);
  std::memcpy(out.data, bytes.data() + data, size_t{4} * rows * cols);
  return out;
}

// Agreement of `ours` (+inf unknown) with the author's map (0 unknown).
struct Agreement {
  int author_valid = 0;
  int ours_valid = 0;
  int both = 0;
  double within_1px = 0;  // share of `both`
  double within_2px = 0;
  double covered = 0;  // share of the author's pixels we also give
};

Agreement Compare(const cv::Mat& ours, const cv::Mat& author) {
  Agreement a;
  int w1 = 0, w2 = 0;
  for (int y = 0; y < ours.rows; ++y) {
    for (int x = 0; x < ours.cols; ++x) {
      const float o = ours.at<float>(y, x), t = author.at<float>(y, x);
      const bool has_o = std::isfinite(o), has_t = t != 0;
      a.ours_valid += has_o;
      a.author_valid += has_t;
      if (has_o && has_t) {
        ++a.both;
        w1 += std::abs(o - t) <= 1;
        w2 += std::abs(o - t) <= 2;
      }
    }
  }
  a.within_1px = a.both > 0 ? double(w1) / a.both : 0;
  a.within_2px = a.both > 0 ? double(w2) / a.both : 0;
  a.covered = a.author_valid > 0 ? double(a.both) / a.author_valid : 0;
  return a;
}

void Print(const char* what, const Agreement& a) {
  std::cout << absl::StrFormat(
      "%s: author %d px, ours %d px, both %d (%.1f %% of the author's); "
      "within 1 px %.1f %%, within 2 px %.1f %%\n",
      what, a.author_valid, a.ours_valid, a.both, 100 * a.covered,
      100 * a.within_1px, 100 * a.within_2px);
}

class RealCaptureTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(Capture() / "capture" / "01-left.png")) {
      GTEST_SKIP() << Capture() << " is absent (no ../shared/data)";
    }
  }
};

struct Decoded {
  DecodedView views[2];
  ViewDisparity disparity;
  Agreement agreement;
};

// Decodes both views with `min_bits` and matches them (view disparity).
absl::StatusOr<Decoded> DecodeAndMatch(const FrameLayout& layout, int min_bits,
                                       const cv::Mat& author) {
  Decoded run;
  DecodeOptions options;
  options.min_bits = min_bits;
  for (int v = 0; v < 2; ++v) {
    ASSIGN_OR_RETURN(ViewFrames frames,
                     LoadLayoutView(layout, Capture(), layout.views[v]));
    ASSIGN_OR_RETURN(run.views[v], Decode(frames, options));
  }
  const MatchOptions match;
  ASSIGN_OR_RETURN(
      run.disparity,
      ComputeViewDisparity(ComputeSubpixelCodes(run.views[0], match),
                           ComputeSubpixelCodes(run.views[1], match), match));
  run.agreement = Compare(run.disparity.left, author);
  return run;
}

TEST_F(RealCaptureTest, DecodesTheUsableBitsAndAgreesWithTheAuthor) {
  ASSERT_OK_AND_ASSIGN(FrameLayout layout, ParseFrameLayout(kLayout));
  ASSERT_OK_AND_ASSIGN(cv::Mat author, ReadNpy(Capture() / "capture" /
                                               "result" / "disparity.npy"));
  ASSERT_EQ(author.size(), cv::Size(1280, 720));
  // Every bit required (min_bits 0, this project's own captures): nothing
  // decodes, the finest planes carry no contrast. Then the sweep on this
  // capture that chose the layout's min_bits (7: the most pixels that the
  // left-right check keeps).
  for (int min_bits : {0, 6, 7, 8, 9}) {
    ASSERT_OK_AND_ASSIGN(Decoded run, DecodeAndMatch(layout, min_bits, author));
    std::cout << absl::StrFormat(
        "min_bits %d: decoded %d / %d of %d / %d lit; matched %d (%d removed "
        "by the left-right check)\n",
        min_bits, run.views[0].valid_pixels, run.views[1].valid_pixels,
        run.views[0].lit_pixels, run.views[1].lit_pixels,
        run.disparity.left_matched, run.disparity.left_rejected);
    Print("  view disparity vs the author's", run.agreement);
    if (min_bits == 0) {
      EXPECT_LT(run.views[0].valid_pixels, 100);
      EXPECT_LT(run.views[1].valid_pixels, 100);
    }
  }

  ASSERT_OK_AND_ASSIGN(Decoded run,
                       DecodeAndMatch(layout, layout.min_bits, author));
  // Bits read per pixel: the finest three planes carry no contrast
  // (README), so hardly any pixel reads 11 or 12 bits.
  for (int v = 0; v < 2; ++v) {
    for (const cv::Mat* bits :
         {&run.views[v].column_bits, &run.views[v].row_bits}) {
      std::vector<int> histogram(13, 0);
      for (int y = 0; y < bits->rows; ++y) {
        for (int x = 0; x < bits->cols; ++x) {
          if (run.views[v].column.at<int32_t>(y, x) >= 0) {
            ++histogram[bits->at<uint8_t>(y, x)];
          }
        }
      }
      std::cout << layout.views[v]
                << (bits == &run.views[v].column_bits ? " column" : " row")
                << " bits read (7..12):";
      for (int k = 7; k <= 12; ++k) std::cout << " " << histogram[k];
      std::cout << "\n";
      EXPECT_LT(histogram[12] + histogram[11],
                (run.views[v].valid_pixels + 99) / 100);
    }
  }
  // Against the author's map (a rough reference: top 9 bits, 5x5 median):
  // measured 99.8 % of the author's pixels covered, 99.9 % of the common
  // ones within 1 px, 100.0 % within 2 px; our count within 0.3 % of
  // the author's. Asserted with margins.
  const Agreement& a = run.agreement;
  EXPECT_GE(a.covered, 0.95);
  EXPECT_GE(a.within_1px, 0.97);
  EXPECT_GE(a.within_2px, 0.99);
  EXPECT_NEAR(a.ours_valid, a.author_valid, 0.05 * a.author_valid);
}

// OpenCV's GrayCodePattern on the same frames, as a user would run it: it
// takes the same frame order (column then row planes, MSB first, each with
// its inverse) but has no code offset and needs every bit to pass its white
// threshold (default 5 grey levels). On every 4th pixel of the left view:
// how many it decodes, and how many of those agree with our decode within
// 2 projector columns once the offset it does not know is taken off.
TEST_F(RealCaptureTest, OpenCvGrayCodePatternCannotReadTheCapture) {
  ASSERT_OK_AND_ASSIGN(FrameLayout layout, ParseFrameLayout(kLayout));
  ASSERT_OK_AND_ASSIGN(ViewFrames frames,
                       LoadLayoutView(layout, Capture(), "left"));
  DecodeOptions options;
  options.min_bits = layout.min_bits;
  ASSERT_OK_AND_ASSIGN(DecodedView ours, Decode(frames, options));
  const std::vector<cv::Mat>& f = frames.exposures[0].frames;
  const std::vector<cv::Mat> planes(f.begin(), f.end() - 2);
  cv::Ptr<cv::structured_light::GrayCodePattern> opencv =
      cv::structured_light::GrayCodePattern::create(3840, 2160);
  ASSERT_EQ(opencv->getNumberOfPatternImages(), planes.size());
  int sampled = 0, ours_valid = 0, decoded = 0, agree = 0;
  for (int y = 0; y < 720; y += 4) {
    for (int x = 0; x < 1280; x += 4) {
      ++sampled;
      const int32_t c = ours.column.at<int32_t>(y, x);
      ours_valid += c >= 0;
      cv::Point p;
      if (opencv->getProjPixel(planes, x, y, p)) continue;  // true = error
      ++decoded;
      agree += c >= 0 && std::abs(p.x - layout.columns.code_offset - c) <= 2;
    }
  }
  std::cout << absl::StrFormat(
      "every 4th pixel (%d): ours decodes %d; OpenCV GrayCodePattern decodes "
      "%d, of which %d agree with ours within 2 projector columns after "
      "subtracting the code offset it does not know\n",
      sampled, ours_valid, decoded, agree);
  EXPECT_LT(decoded, ours_valid / 10);
}

// The same through `hdrstereo-proc sl disparity --layout`, as a user would
// run it on the folder.
TEST_F(RealCaptureTest, TheToolDecodesTheCaptureFromItsLayoutFile) {
  ::hdrstereo::testing::TempDir dir;
  { std::ofstream(dir / "zengzhik.json") << kLayout; }
  const ::hdrstereo::testing::CommandResult run = ::hdrstereo::testing::Proc(
      {"sl", "disparity", "--capture", Capture().string(), "--layout",
       (dir / "zengzhik.json").string(), "--out", (dir / "gt").string(),
       "--no-illumination"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  ASSERT_OK_AND_ASSIGN(cv::Mat disp0, io::ReadPfm(dir / "gt" / "disp0GT.pfm"));
  ASSERT_OK_AND_ASSIGN(cv::Mat author, ReadNpy(Capture() / "capture" /
                                               "result" / "disparity.npy"));
  ASSERT_OK_AND_ASSIGN(io::DecodedImage mask,
                       io::DecodeImageFile(dir / "gt" / "mask0nocc.png"));
  EXPECT_EQ(mask.pixels.size(), author.size());
  const Agreement a = Compare(disp0, author);
  Print("hdrstereo-proc sl disparity", a);
  // The same agreement as the library's view disparity (plus small holes
  // the tool fills).
  EXPECT_GE(a.covered, 0.95);
  EXPECT_GE(a.within_1px, 0.97);
  EXPECT_GE(a.within_2px, 0.99);
}

}  // namespace
}  // namespace hdrstereo::structured_light
