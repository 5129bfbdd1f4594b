// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/image.h"

#include <libraw/libraw.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/exif.h"
#include "processing/io/hdr_formats.h"

namespace hdrstereo::io {

std::string LowerExtension(const std::filesystem::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

namespace {

bool IsRawSuffix(absl::string_view ext) {
  static const char* const kRaw[] = {".cr2", ".cr3", ".crw", ".nef", ".nrw",
                                     ".arw", ".srf", ".sr2", ".dng", ".orf",
                                     ".rw2", ".raf", ".pef", ".srw", ".raw",
                                     ".3fr", ".erf", ".kdc", ".mrw", ".x3f"};
  return std::find(std::begin(kRaw), std::end(kRaw), ext) != std::end(kRaw);
}

// LibRaw's cap on its raw buffer: the bytes of a 16-bit sensor of the image
// limits' pixels, at most LibRaw's own default.
unsigned RawMemoryLimitMb() {
  const int64_t pixels =
      std::min<int64_t>(DecodedImageLimits().max_pixels, int64_t{1} << 52);
  return static_cast<unsigned>(
      std::clamp<int64_t>((pixels * 2) >> 20, 1, LIBRAW_MAX_ALLOC_MB_DEFAULT));
}

// DecodeRawBytes without the source in its errors.
absl::StatusOr<DecodedImage> DecodeRaw(absl::string_view bytes) {
  auto raw = std::make_unique<LibRaw>();
  raw->imgdata.params.output_bps = 16;
  raw->imgdata.params.gamm[0] = 1.0;  // linear
  raw->imgdata.params.gamm[1] = 1.0;
  raw->imgdata.params.no_auto_bright = 1;
  raw->imgdata.params.use_camera_wb = 1;
  raw->imgdata.params.use_auto_wb = 0;
  raw->imgdata.params.output_color = 1;  // sRGB primaries, linear
  raw->imgdata.params.max_raw_memory_mb = RawMemoryLimitMb();
  auto fail = [&](absl::string_view stage, int rc) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot decode RAW (", stage, "): ", libraw_strerror(rc)));
  };
  // LibRaw only reads the buffer; its signature is not const.
  if (int rc = raw->open_buffer(const_cast<char*>(bytes.data()), bytes.size());
      rc != LIBRAW_SUCCESS) {
    return fail("open", rc);
  }
  // The sizes the file declares, before LibRaw allocates for them (the
  // demosaiced image holds four 16-bit values a pixel).
  const libraw_image_sizes_t& sizes = raw->imgdata.sizes;
  RETURN_IF_ERROR(
      ImageBytes("RAW sensor", sizes.raw_width, sizes.raw_height, 1, 2)
          .status());
  RETURN_IF_ERROR(
      ImageBytes("RAW image", sizes.width, sizes.height, 4, 2).status());
  if (int rc = raw->unpack(); rc != LIBRAW_SUCCESS) return fail("unpack", rc);
  RawLevels levels;
  levels.sensor_size = cv::Size(sizes.raw_width, sizes.raw_height);
  levels.active_area =
      cv::Rect(sizes.left_margin, sizes.top_margin, sizes.width, sizes.height);
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 2; ++x) {
      const int c = raw->COLOR(y, x);  // index into cdesc ("RGBG")
      levels.cfa_pattern += c >= 0 && c < 4 ? raw->imgdata.idata.cdesc[c] : '?';
    }
  }
  if (int rc = raw->dcraw_process(); rc != LIBRAW_SUCCESS) {
    return fail("demosaic", rc);
  }
  // The levels dcraw_process scaled by, as read at unpack (processing
  // folds the black level into the data): the common black, the first
  // colour's offset and the first entry of a black-level pattern.
  const libraw_colordata_t& color = raw->imgdata.rawdata.color;
  const bool pattern = color.cblack[4] > 0 && color.cblack[5] > 0;
  levels.black = static_cast<int>(color.black + color.cblack[0] +
                                  (pattern ? color.cblack[6] : 0));
  levels.white = static_cast<int>(color.maximum);
  int rc = LIBRAW_SUCCESS;
  libraw_processed_image_t* img = raw->dcraw_make_mem_image(&rc);
  if (img == nullptr || rc != LIBRAW_SUCCESS) {
    if (img != nullptr) LibRaw::dcraw_clear_mem(img);
    return fail("make image", rc);
  }
  std::unique_ptr<libraw_processed_image_t, void (*)(libraw_processed_image_t*)>
      guard(img, &LibRaw::dcraw_clear_mem);
  if (img->type != LIBRAW_IMAGE_BITMAP || img->bits != 16 ||
      (img->colors != 3 && img->colors != 1)) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected LibRaw output: ", img->colors, " colours, ",
                     img->bits, " bits"));
  }
  DecodedImage out;
  cv::Mat wrapped(img->height, img->width, CV_16UC(img->colors), img->data);
  if (img->colors == 3) {
    cv::cvtColor(wrapped, out.pixels, cv::COLOR_RGB2BGR);
  } else {
    out.pixels = wrapped.clone();
  }
  // TIFF-based RAW (DNG, CR2, NEF, ARW, ...): the file's own EXIF, where 0
  // means unknown (LibRaw would fall back to the APEX fields, whose 0 reads
  // as 1 s and f/1, as in Magic Lantern's DNGs); other RAW: LibRaw's values.
  const ExifInfo exif = ReadRawMetadata(bytes);
  out.metadata.exposure_s = exif.exposure_s;
  out.metadata.iso = exif.iso;
  out.metadata.aperture = exif.aperture;
  out.metadata.camera =
      absl::StrCat(raw->imgdata.idata.make, " ", raw->imgdata.idata.model);
  out.metadata.linear = true;
  const float* mul = raw->imgdata.color.cam_mul;
  out.metadata.white_balance =
      std::array<float, 4>{mul[0], mul[1], mul[2], mul[3]};
  out.metadata.raw = levels;
  return out;
}

// DecodeImageBytes without the source in its errors; `ext` lower case.
absl::StatusOr<DecodedImage> Decode(absl::string_view bytes,
                                    absl::string_view ext) {
  if (IsRawSuffix(ext)) return DecodeRaw(bytes);
  if (ext == ".pfm" || ext == ".exr" || ext == ".hdr") {
    ASSIGN_OR_RETURN(cv::Mat f, ext == ".pfm"   ? ParsePfm(bytes)
                                : ext == ".exr" ? ParseExr(bytes)
                                                : ParseRgbe(bytes));
    DecodedImage out;
    out.pixels = std::move(f);
    out.metadata.linear = true;
    return out;
  }
  if (bytes.empty()) return absl::InvalidArgumentError("empty image file");
  DecodedImage out;
  ASSIGN_OR_RETURN(
      out.pixels,
      DecodeWithOpenCv(bytes, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR));
  int depth = out.pixels.depth();
  if (depth != CV_8U && depth != CV_16U && depth != CV_32F) {
    out.pixels.convertTo(out.pixels, CV_32F);
  }
  if (out.pixels.channels() == 4) {
    cv::cvtColor(out.pixels, out.pixels, cv::COLOR_BGRA2BGR);
  }
  ExifInfo exif = ParseExifFromFile(bytes);
  out.metadata.exposure_s = exif.exposure_s;
  out.metadata.iso = exif.iso;
  out.metadata.aperture = exif.aperture;
  out.metadata.camera = exif.camera;
  out.metadata.linear = out.pixels.depth() == CV_32F;
  return out;
}

}  // namespace

bool IsRawExtension(const std::filesystem::path& path) {
  return IsRawSuffix(LowerExtension(path));
}

absl::Status WithSource(absl::string_view source, const absl::Status& status) {
  if (status.ok()) return status;
  return absl::Status(status.code(),
                      absl::StrCat(source, ": ", status.message()));
}

absl::StatusOr<std::string> ReadFileBytes(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    return absl::NotFoundError(
        absl::StrCat("no such file (or not a regular file): ", path.string()));
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return absl::PermissionDeniedError(
        absl::StrCat("cannot open ", path.string()));
  }
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) {
    return absl::DataLossError(absl::StrCat("cannot read ", path.string()));
  }
  return std::move(buffer).str();
}

absl::StatusOr<cv::Mat> DecodeWithOpenCv(absl::string_view bytes, int flags) {
  RETURN_IF_ERROR(CheckRange("encoded image bytes",
                             static_cast<int64_t>(bytes.size()), 1,
                             std::numeric_limits<int>::max()));
  // OpenCV picks its decoder by the bytes, not the file's name: only the
  // formats cameras write reach it, so that bytes named .png cannot reach
  // its RGBE or EXR decoder (ParseRgbe, ParseExr) or any other.
  static constexpr absl::string_view kMagics[] = {
      "\xff\xd8\xff", "\x89PNG\r\n\x1a\n", absl::string_view("II*\0", 4),
      absl::string_view("MM\0*", 4)};
  if (std::none_of(std::begin(kMagics), std::end(kMagics),
                   [&](absl::string_view magic) {
                     return absl::StartsWith(bytes, magic);
                   })) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a JPEG, PNG or TIFF file: it starts ",
                     QuoteInput(bytes.substr(0, 8))));
  }
  // imdecode only reads the buffer; cv::Mat's constructor is not const.
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1,
                       const_cast<char*>(bytes.data()));
  cv::Mat image;
  try {
    image = cv::imdecode(buffer, flags);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot decode: ", e.what()));
  }
  if (image.empty()) {
    return absl::InvalidArgumentError(
        "cannot decode (corrupt or unsupported format)");
  }
  return image;
}

absl::StatusOr<DecodedImage> DecodeImageBytes(absl::string_view bytes,
                                              absl::string_view extension) {
  return WithSource(kInMemory, Decode(bytes, absl::AsciiStrToLower(extension)));
}

absl::StatusOr<DecodedImage> DecodeImageFile(
    const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  return WithSource(path.string(), Decode(bytes, LowerExtension(path)));
}

absl::StatusOr<DecodedImage> DecodeRawBytes(absl::string_view bytes) {
  return WithSource(kInMemory, DecodeRaw(bytes));
}

absl::StatusOr<DecodedImage> DecodeRawFile(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  return WithSource(path.string(), DecodeRaw(bytes));
}

cv::Mat ToFloat(const cv::Mat& pixels) {
  cv::Mat out;
  double scale = pixels.depth() == CV_8U    ? 1.0 / 255.0
                 : pixels.depth() == CV_16U ? 1.0 / 65535.0
                                            : 1.0;
  pixels.convertTo(out, CV_32F, scale);
  return out;
}

cv::Mat To8Bit(const cv::Mat& pixels) {
  if (pixels.depth() == CV_8U) return pixels;
  cv::Mat out;
  pixels.convertTo(out, CV_8U, pixels.depth() == CV_16U ? 1.0 / 257.0 : 255.0);
  return out;
}

}  // namespace hdrstereo::io
