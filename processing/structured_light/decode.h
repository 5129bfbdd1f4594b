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

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
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
  // 65535; 0.02 is 5 grey levels of an 8-bit frame, the plain decoder's
  // threshold of decode_coverage_test.cc) and at least
  // `min_relative_contrast` of white - black where the finest stripes may
  // be below the camera's resolution: in min_bits mode everywhere (there it
  // marks the plane where the contrast fades, chosen on the zengzhik
  // capture); with every bit required only when the camera does not
  // resolve the finest stripes (a camera pixel spans more than their width,
  // 2 projector pixels, on average over the view), where a
  // contrast above the floor may be aliasing, i.e. unequal parts of two
  // stripes (Decode then decodes again with the test). Every bit must count
  // (but see min_bits).
  //
  // Why not everywhere: where the camera resolves the stripes, blur alone
  // lowers the finest planes' contrast on every pixel: with about one
  // projector pixel per camera pixel and a projector blur of 1-1.6 pixels
  // the finest plane keeps 10-40 % of white - black, and a relative test of
  // 0.25 dropped most of such a capture (the simulator's lab-lamp,
  // shadowed, two-lamps and desk-lamp scenes at 1:1, blur 1 and 1.6, 1x and
  // 8x noise: it kept 0-99.8 % of the pixels a plain decoder reads
  // consistently, under 90 % in 12 of the 16 cases; a Gray-code bit read
  // wrongly at its own stripe edge only gives the neighbouring code). The
  // 5-level floor (was 2) is what keeps noise out: on the same scenes with
  // 8x the sensor's noise and blur 1.6 a 3-level floor gives 0.17-0.41 %
  // wrong codes, the 5-level floor none
  // (tests/unit/structured_light/decode_coverage_test.cc); the price is the
  // lit pixels where the projector adds only 2-4 grey levels (decode_test).
  double min_contrast = 0.02;
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

  // INVALID_ARGUMENT naming the first field that breaks a rule.
  absl::Status Validate() const;
};
// Canonical JSON (processing/base/options.h).
void to_json(nlohmann::json& j, const DecodeOptions& o);

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
