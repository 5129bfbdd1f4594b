// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/hdr_formats.h"

#include <Imath/half.h>
#include <OpenEXR/IexBaseExc.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfName.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>
#include <OpenEXR/ImfVersion.h>
#include <stb_image.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"

namespace hdrstereo::io {
namespace {

absl::Status CheckFloatImage(const std::filesystem::path& path,
                             const cv::Mat& image) {
  if (image.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("empty image for ", path.string()));
  }
  if (image.channels() != 1 && image.channels() != 3) {
    return absl::InvalidArgumentError(absl::StrCat("need 1 or 3 channels for ",
                                                   path.string(), ", got ",
                                                   image.channels()));
  }
  return absl::OkStatus();
}

// Float RGB(A) or grey, in file order, from an OpenCV image.
cv::Mat ToRgbFloat(const cv::Mat& image) {
  cv::Mat f;
  image.convertTo(f, CV_32F);
  if (f.channels() == 3) cv::cvtColor(f, f, cv::COLOR_BGR2RGB);
  return f;
}

// The next whitespace-delimited token of a PFM header, "" at the end.
absl::string_view NextToken(absl::string_view data, size_t& at) {
  auto space = [&](size_t i) {
    return std::isspace(static_cast<unsigned char>(data[i])) != 0;
  };
  while (at < data.size() && space(at)) ++at;
  const size_t start = at;
  while (at < data.size() && !space(at)) ++at;
  return data.substr(start, at - start);
}

absl::Status BadPfm(absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat("corrupt PFM: ", why));
}

// A PFM width or height: a whole number (its range is ImageBytes').
absl::StatusOr<int64_t> PfmDimension(absl::string_view field,
                                     absl::string_view token) {
  int64_t value = 0;
  if (!absl::SimpleAtoi(token, &value)) {
    return BadPfm(absl::StrCat(field, " ", QuoteInput(token),
                               " is not a whole number of 64 bits"));
  }
  return value;
}

uint32_t ByteSwap32(uint32_t v) {
  return (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24);
}

// An OpenEXR input stream over bytes in memory (StdISStream would copy
// them). OpenEXR turns its exceptions into our errors (ParseExr).
class MemoryIStream : public Imf::IStream {
 public:
  explicit MemoryIStream(absl::string_view bytes)
      : Imf::IStream(kInMemory), bytes_(bytes) {}
  bool read(char c[], int n) override {
    if (n < 0 || static_cast<size_t>(n) > bytes_.size() - at_) {
      throw Iex::InputExc("unexpected end of file");
    }
    std::memcpy(c, bytes_.data() + at_, n);
    at_ += n;
    return at_ < bytes_.size();
  }
  uint64_t tellg() override { return at_; }
  void seekg(uint64_t pos) override {
    if (pos > bytes_.size()) throw Iex::InputExc("seek past the end of file");
    at_ = pos;
  }
  void clear() override {}

 private:
  absl::string_view bytes_;
  size_t at_ = 0;
};

uint32_t LittleEndian32(absl::string_view bytes, size_t at) {
  uint32_t v = 0;
  for (int i = 3; i >= 0; --i) {
    v = v << 8 | static_cast<unsigned char>(bytes[at + i]);
  }
  return v;
}

// The NUL-terminated name (at most Imf::Name::MAX_LENGTH characters) at
// `at`, which moves past it; nullopt when the file ends first.
std::optional<absl::string_view> ExrName(absl::string_view bytes, size_t& at) {
  const size_t end = bytes.find('\0', at);
  if (end == absl::string_view::npos ||
      end - at > static_cast<size_t>(Imf::Name::MAX_LENGTH)) {
    return std::nullopt;
  }
  const absl::string_view name = bytes.substr(at, end - at);
  at = end + 1;
  return name;
}

// Walks the header's attributes before OpenEXR reads them: OpenEXR
// allocates each attribute's declared size (up to 2 GiB) before it finds
// that the file is shorter. Returns the version field.
absl::StatusOr<int> CheckExrAttributes(absl::string_view bytes) {
  if (bytes.size() < 8 || LittleEndian32(bytes, 0) != Imf::MAGIC) {
    return absl::InvalidArgumentError("no OpenEXR magic number");
  }
  const int version = static_cast<int>(LittleEndian32(bytes, 4));
  if (Imf::isMultiPart(version) || Imf::isNonImage(version)) {
    return absl::InvalidArgumentError(
        "multi-part and deep files are not supported");
  }
  size_t at = 8;
  while (true) {
    const std::optional<absl::string_view> name = ExrName(bytes, at);
    if (!name.has_value()) {
      return absl::InvalidArgumentError("an attribute name runs off");
    }
    if (name->empty()) return version;  // the end of the header
    if (!ExrName(bytes, at).has_value() || bytes.size() - at < 4) {
      return absl::InvalidArgumentError(
          absl::StrCat("attribute ", QuoteInput(*name), " is cut off"));
    }
    const int64_t size = static_cast<int32_t>(LittleEndian32(bytes, at));
    at += 4;
    RETURN_IF_ERROR(
        CheckRange(absl::StrCat("attribute ", QuoteInput(*name), " size"), size,
                   0, static_cast<int64_t>(bytes.size() - at)));
    at += size;
  }
}

// The bytes OpenEXR holds for `width` x `height` pixels of every channel
// of the file (4 bytes a value at most): within the image limits and at
// most those of an RGBA float image of the limits' pixels.
absl::Status CheckExrBlock(absl::string_view what, int64_t width,
                           int64_t height, int64_t channels) {
  ASSIGN_OR_RETURN(const size_t bytes,
                   ImageBytes(what, width, height, channels, 4));
  constexpr int64_t kRgbaFloat = 4 * sizeof(float);
  const int64_t limit =
      std::min(DecodedImageLimits().max_pixels,
               std::numeric_limits<int64_t>::max() / kRgbaFloat) *
      kRgbaFloat;
  return CheckRange(absl::StrCat(what, " bytes (all channels)"),
                    static_cast<int64_t>(bytes), 1, limit);
}

// Scan lines in a chunk of a scanline file, by compression (OpenEXR's own
// numbers).
int ExrLinesPerChunk(Imf::Compression compression) {
  switch (compression) {
    case Imf::ZIP_COMPRESSION:
    case Imf::PXR24_COMPRESSION:
      return 16;
    case Imf::PIZ_COMPRESSION:
    case Imf::B44_COMPRESSION:
    case Imf::B44A_COMPRESSION:
    case Imf::DWAA_COMPRESSION:
      return 32;
    case Imf::DWAB_COMPRESSION:
      return 256;
    default:
      return 1;
  }
}

int64_t CeilDiv(int64_t a, int64_t b) { return (a + b - 1) / b; }

// What OpenEXR allocates as it opens a file with `header`, bounded before
// it does: the image, one chunk's buffers and a tiled file's offset table.
absl::Status CheckExrHeader(const Imf::Header& header, size_t file_bytes) {
  const Imath::Box2i& dw = header.dataWindow();
  const int64_t width = int64_t{dw.max.x} - dw.min.x + 1;
  const int64_t height = int64_t{dw.max.y} - dw.min.y + 1;
  int64_t channels = 0;  // ChannelList's iterators are not std iterators
  for (auto it = header.channels().begin(); it != header.channels().end();
       ++it) {
    ++channels;
  }
  RETURN_IF_ERROR(CheckExrBlock("data window", width, height, channels));
  if (!header.hasTileDescription()) {
    return CheckExrBlock("scan-line block", width,
                         ExrLinesPerChunk(header.compression()), channels);
  }
  const Imf::TileDescription& tile = header.tileDescription();
  RETURN_IF_ERROR(CheckExrBlock("tile", tile.xSize, tile.ySize, channels));
  // InputFile reads a tiled file into scan lines a row of tiles at a time.
  RETURN_IF_ERROR(CheckExrBlock("row of tiles", width, tile.ySize, channels));
  // The offset table (8 bytes a tile, more at lower levels) is in the file.
  const int64_t tiles =
      CeilDiv(width, tile.xSize) * CeilDiv(height, tile.ySize);
  return CheckedMultiply("tile offsets (level 0 tiles x 8 bytes)", tiles, 8,
                         file_bytes)
      .status();
}

// ParseExr without "cannot read EXR: " before its errors.
absl::StatusOr<cv::Mat> ReadExrImage(absl::string_view bytes) {
  ASSIGN_OR_RETURN(int version, CheckExrAttributes(bytes));
  // OpenEXR throws Iex exceptions and std::bad_alloc, all std::exception.
  try {
    MemoryIStream stream(bytes);
    stream.seekg(8);  // past the magic number and the version
    Imf::Header header;
    header.readFrom(stream, version);
    RETURN_IF_ERROR(CheckExrHeader(header, bytes.size()));
    stream.seekg(0);
    Imf::InputFile file(stream);
    const Imath::Box2i dw = file.header().dataWindow();
    const Imf::ChannelList& list = file.header().channels();
    const bool grey =
        list.findChannel("Y") != nullptr && list.findChannel("R") == nullptr;
    const int channels = grey ? 1 : 3;
    cv::Mat rgb(dw.max.y - dw.min.y + 1, dw.max.x - dw.min.x + 1,
                CV_32FC(channels), cv::Scalar::all(0));
    const size_t xs = sizeof(float) * channels;
    Imf::FrameBuffer fb;
    const char* const kNames[3] = {"R", "G", "B"};
    for (int c = 0; c < channels; ++c) {
      fb.insert(grey ? "Y" : kNames[c],
                Imf::Slice::Make(Imf::FLOAT, rgb.ptr<float>() + c, dw, xs,
                                 rgb.step[0]));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    if (channels == 3) cv::cvtColor(rgb, rgb, cv::COLOR_RGB2BGR);
    return rgb;
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(e.what());
  }
}

}  // namespace

absl::Status WritePfm(const std::filesystem::path& path, const cv::Mat& image) {
  RETURN_IF_ERROR(CheckFloatImage(path, image));
  cv::Mat rgb = ToRgbFloat(image);
  const int channels = rgb.channels();
  std::string out = absl::StrCat(channels == 3 ? "PF" : "Pf", "\n", rgb.cols,
                                 " ", rgb.rows, "\n-1.0\n");
  const size_t row_bytes = sizeof(float) * rgb.cols * channels;
  const size_t header = out.size();
  out.resize(header + row_bytes * rgb.rows);
  for (int y = 0; y < rgb.rows; ++y) {  // bottom row first
    const float* src = rgb.ptr<float>(rgb.rows - 1 - y);
    char* dst = out.data() + header + row_bytes * y;
    if constexpr (std::endian::native == std::endian::little) {
      std::memcpy(dst, src, row_bytes);
    } else {
      for (size_t i = 0; i < row_bytes / 4; ++i) {
        uint32_t v;
        std::memcpy(&v, src + i, 4);
        v = ByteSwap32(v);
        std::memcpy(dst + 4 * i, &v, 4);
      }
    }
  }
  return WriteFileAtomically(path, out);
}

absl::StatusOr<cv::Mat> ParsePfm(absl::string_view bytes) {
  size_t at = 0;
  const absl::string_view magic = NextToken(bytes, at);
  if (magic != "PF" && magic != "Pf") {
    return BadPfm(absl::StrCat("no PF/Pf magic at the start of ",
                               QuoteInput(bytes.substr(0, 16))));
  }
  const int channels = magic == "PF" ? 3 : 1;
  ASSIGN_OR_RETURN(const int64_t width,
                   PfmDimension("width", NextToken(bytes, at)));
  ASSIGN_OR_RETURN(const int64_t height,
                   PfmDimension("height", NextToken(bytes, at)));
  const absl::string_view scale_token = NextToken(bytes, at);
  double scale = 0;
  if (!absl::SimpleAtod(scale_token, &scale) || !std::isfinite(scale) ||
      scale == 0) {
    return BadPfm(absl::StrCat("scale ", QuoteInput(scale_token),
                               " is not a finite, non-zero number"));
  }
  ASSIGN_OR_RETURN(const size_t pixel_bytes,
                   ImageBytes("PFM", width, height, channels, sizeof(float)));
  // Exactly one whitespace character ends the header.
  if (at == bytes.size() ||
      !std::isspace(static_cast<unsigned char>(bytes[at]))) {
    return BadPfm("the header does not end in whitespace");
  }
  ++at;
  if (bytes.size() - at < pixel_bytes) {
    return BadPfm(absl::StrCat("truncated: ", bytes.size() - at,
                               " bytes of pixels, the header declares ",
                               pixel_bytes));
  }
  const size_t row_bytes = pixel_bytes / height;
  const bool file_little = scale < 0;
  const bool swap = file_little != (std::endian::native == std::endian::little);
  cv::Mat img(static_cast<int>(height), static_cast<int>(width),
              CV_32FC(channels));
  for (int y = 0; y < img.rows; ++y) {
    float* dst = img.ptr<float>(img.rows - 1 - y);
    const char* src = bytes.data() + at + row_bytes * y;
    std::memcpy(dst, src, row_bytes);
    if (swap) {
      auto* words = reinterpret_cast<uint32_t*>(dst);
      for (size_t i = 0; i < row_bytes / 4; ++i)
        words[i] = ByteSwap32(words[i]);
    }
  }
  if (channels == 3) cv::cvtColor(img, img, cv::COLOR_RGB2BGR);
  return img;
}

absl::StatusOr<cv::Mat> ReadPfm(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  return WithSource(path.string(), ParsePfm(bytes));
}

absl::Status WriteExr(const std::filesystem::path& path, const cv::Mat& image,
                      ExrPixelType type) {
  RETURN_IF_ERROR(CheckFloatImage(path, image));
  cv::Mat rgb = ToRgbFloat(image);
  if (!rgb.isContinuous()) rgb = rgb.clone();
  const int channels = rgb.channels();
  const Imf::PixelType pixel =
      type == ExrPixelType::kHalf ? Imf::HALF : Imf::FLOAT;
  try {
    Imf::Header header(rgb.cols, rgb.rows);
    header.compression() = Imf::ZIP_COMPRESSION;
    const char* const kNames[3] = {"R", "G", "B"};
    Imf::FrameBuffer fb;
    // The frame buffer must hold the file's pixel type.
    std::vector<half> halves;
    char* base = reinterpret_cast<char*>(rgb.data);
    size_t elem = sizeof(float);
    if (pixel == Imf::HALF) {
      const size_t count = rgb.total() * channels;
      halves.resize(count);
      const float* src = rgb.ptr<float>();
      for (size_t i = 0; i < count; ++i) halves[i] = half(src[i]);
      base = reinterpret_cast<char*>(halves.data());
      elem = sizeof(half);
    }
    const size_t xs = elem * channels;
    const size_t ys = xs * rgb.cols;
    for (int c = 0; c < channels; ++c) {
      const char* name = channels == 1 ? "Y" : kNames[c];
      header.channels().insert(name, Imf::Channel(pixel));
      fb.insert(name, Imf::Slice(pixel, base + elem * c, xs, ys));
    }
    Imf::StdOSStream stream;
    {
      Imf::OutputFile file(stream, header);
      file.setFrameBuffer(fb);
      file.writePixels(rgb.rows);
    }
    return WriteFileAtomically(path, stream.str());
  } catch (const std::exception& e) {
    return absl::InternalError(
        absl::StrCat("cannot write EXR ", path.string(), ": ", e.what()));
  }
}

absl::StatusOr<cv::Mat> ParseExr(absl::string_view bytes) {
  absl::StatusOr<cv::Mat> image = ReadExrImage(bytes);
  if (!image.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read EXR: ", image.status().message()));
  }
  return image;
}

absl::StatusOr<cv::Mat> ReadExr(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  return WithSource(path.string(), ParseExr(bytes));
}

absl::Status WriteEncoded(const std::filesystem::path& path,
                          const cv::Mat& image) {
  if (image.empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("empty image for ", path.string()));
  }
  std::vector<uchar> buf;
  try {
    if (!cv::imencode(path.extension().string(), image, buf)) {
      return absl::InvalidArgumentError(
          absl::StrCat("cannot encode ", path.string()));
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot encode ", path.string(), ": ", e.what()));
  }
  return WriteFileAtomically(
      path,
      absl::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

absl::Status WriteRgbe(const std::filesystem::path& path,
                       const cv::Mat& image) {
  RETURN_IF_ERROR(CheckFloatImage(path, image));
  cv::Mat f;
  image.convertTo(f, CV_32F);
  if (f.channels() == 1) cv::cvtColor(f, f, cv::COLOR_GRAY2BGR);
  std::vector<uchar> buf;
  try {
    if (!cv::imencode(".hdr", f, buf)) {
      return absl::InternalError(
          absl::StrCat("cannot encode RGBE ", path.string()));
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("cannot encode RGBE ", path.string(), ": ", e.what()));
  }
  return WriteFileAtomically(
      path,
      absl::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

absl::StatusOr<cv::Mat> ParseRgbe(absl::string_view bytes) {
  // stb_image, not OpenCV: OpenCV 4.6 decodes RGBE only from a temporary
  // file and leaks that file's descriptor on every header or scanline error
  // (one per malformed file, found by rgbe_fuzzer), which a long-running
  // daemon cannot afford. stb_image reads from memory.
  const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max()) ||
      !stbi_is_hdr_from_memory(data, static_cast<int>(bytes.size()))) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a Radiance RGBE file: it starts ",
                     QuoteInput(bytes.substr(0, 16))));
  }
  const int length = static_cast<int>(bytes.size());
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(data, length, &width, &height, &channels)) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt RGBE file: ", stbi_failure_reason()));
  }
  RETURN_IF_ERROR(ImageBytes("RGBE", width, height, 3, sizeof(float)).status());
  std::unique_ptr<float, decltype(&stbi_image_free)> pixels(
      stbi_loadf_from_memory(data, length, &width, &height, &channels, 3),
      &stbi_image_free);
  if (pixels == nullptr) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt RGBE file: ", stbi_failure_reason()));
  }
  cv::Mat bgr;
  cv::cvtColor(cv::Mat(height, width, CV_32FC3, pixels.get()), bgr,
               cv::COLOR_RGB2BGR);
  return bgr;
}

absl::StatusOr<cv::Mat> ReadRgbe(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(const std::string bytes, ReadFileBytes(path));
  return WithSource(path.string(), ParseRgbe(bytes));
}

absl::Status WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.depth() != CV_8U && image.depth() != CV_16U) {
    return absl::InvalidArgumentError(
        absl::StrCat("PNG needs an 8- or 16-bit image for ", path.string()));
  }
  if (LowerExtension(path) != ".png") {
    return absl::InvalidArgumentError(
        absl::StrCat("PNG file name must end in .png: ", path.string()));
  }
  return WriteEncoded(path, image);
}

absl::Status WriteImage(const std::filesystem::path& path,
                        const cv::Mat& image) {
  const std::string ext = LowerExtension(path);
  if (ext == ".pfm") return WritePfm(path, image);
  if (ext == ".exr") return WriteExr(path, image, ExrPixelType::kHalf);
  if (ext == ".hdr") return WriteRgbe(path, image);
  return WriteEncoded(path, image);
}

}  // namespace hdrstereo::io
