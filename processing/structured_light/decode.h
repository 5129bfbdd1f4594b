// SPDX-License-Identifier: GPL-3.0-or-later
//
// Per-view decoding of Gray-code structured light (Scharstein & Szeliski
// 2003; thesis 4.2.1): every bit plane is compared with its inverse (no
// global threshold), a pixel needs a minimum contrast on every bit, the
// shadow mask comes from white - black, and with several exposures each pixel
// uses the exposure with the best contrast. The result is the projector
// column and row seen by every camera pixel, or invalid.
//
// Speed: rows run in parallel (cv::parallel_for_), and the per-bit inner loop
// is branch-free on 8- or 16-bit pixels so the compiler vectorises it.
#ifndef HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DECODE_H_
#define HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DECODE_H_

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "processing/structured_light/gray_code.h"

namespace hdrstereo::structured_light {

// The frames of one view at one exposure, in AllPatterns(column bits, row
// bits) order: column bit planes from the most significant (each followed
// by its inverse), row bit planes, white, black. All frames have the same size
// and type: CV_8U or CV_16U, one or three channels (three are converted to
// grey).
struct ExposureFrames {
  double exposure_s = 0;  // informational (file names, reports)
  std::vector<cv::Mat> frames;
};

struct ViewFrames {
  cv::Size projector_size{1024, 768};
  // The code projected for column x is gray(x + column_offset) in
  // column_bits bits (0: BitCount(width), this project's own patterns);
  // the same for rows. Other labs centre their codes (e.g. offset 128 for
  // 3840 columns in 12 bits).
  int column_bits = 0;
  int row_bits = 0;
  int column_offset = 0;
  int row_offset = 0;
  std::vector<ExposureFrames> exposures;  // at least one
};

struct DecodeOptions {
  // A bit is decided by the sign of pattern - inverse. It counts only when
  // |pattern - inverse| is at least `min_contrast` of full scale (255 or
  // 65535; 0.008 is 2 grey levels of an 8-bit frame, above the noise of a
  // difference) and at least `min_relative_contrast` of white - black (a
  // much smaller swing than the full projector swing means the pixel mixes
  // two stripes, e.g. at a blurred stripe edge). Every bit must count
  // (but see min_bits).
  double min_contrast = 0.008;
  double min_relative_contrast = 0.25;
  // 0: every bit must count (this project's patterns are sized for the
  // camera). N > 0, for captures whose finest stripes are below the
  // camera's resolution: each code is read from its most significant bit
  // down to the last bit that counts; one bit without contrast may lie
  // between counted ones (the pixel straddles that plane's stripe edge; in
  // a Gray code only that bit changes there, so the pixel is placed on the
  // edge, or invalid when flipping the bit does not give the neighbouring
  // code). A pixel is kept when at least N bits of its column and of its
  // row code were read; it stands for the middle of the range of projector
  // columns (rows) those bits allow, and DecodedView::column_bits/row_bits
  // record how many were read.
  int min_bits = 0;
  // Minimum white - black for a pixel to count as lit by the projector;
  // pixels below it are in projector shadow (or saturated) in every
  // exposure and are never decoded.
  double min_lit = 0.015;
  // Pixels at or above this fraction of full scale are saturated; a bit
  // whose pattern and inverse are both saturated has no contrast.
  double saturation = 0.995;
};

struct DecodedView {
  cv::Mat column;  // CV_32SC1 projector column, -1 = invalid
  cv::Mat row;     // CV_32SC1 projector row, -1 = invalid
  // CV_8UC1 bits read per valid pixel (0 where invalid); with min_bits 0
  // always all of them. A pixel with k of B bits stands for 2^(B - k)
  // projector columns (rows).
  cv::Mat column_bits;
  cv::Mat row_bits;
  int column_code_bits = 0;  // B of the columns
  int row_code_bits = 0;
  cv::Mat confidence;  // CV_32FC1 min bit contrast / full scale, 0 = invalid
  cv::Mat lit;         // CV_8UC1 255 where white - black passed min_lit
  cv::Mat exposure;    // CV_8UC1 index of the exposure used (255 = none)
  int valid_pixels = 0;
  int lit_pixels = 0;
  // Human-readable problems that did not stop decoding (e.g. "no pixel is
  // lit by the projector: all-invalid map").
  std::vector<std::string> warnings;
};

// Checks the frames (count, presence, size, type) and decodes them.
// INVALID_ARGUMENT names the missing or mismatching frame by pattern id,
// e.g. "exposure 0: frame col_b03_inv is missing".
absl::StatusOr<DecodedView> Decode(const ViewFrames& view,
                                   const DecodeOptions& options = {});

// The pattern id of frame `index` in AllPatterns(size) order, with "_inv"
// for inverses: "col_b03_inv", "white".
std::string FrameId(const Pattern& pattern);

}  // namespace hdrstereo::structured_light

#endif  // HDRSTEREO_PROCESSING_STRUCTURED_LIGHT_DECODE_H_
