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
#include "absl/strings/str_split.h"
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
  // Exactly one whitespace character ends the header (NextToken stopped at
  // it, or at the end of the data).
  if (at == bytes.size()) {
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

// Why not a library: OpenCV 4.6 decodes RGBE only through a temporary file
// and leaks that file's descriptor on every malformed header or scanline
// (found by rgbe_fuzzer: a daemon reading other labs' files runs out of
// descriptors), and Debian's stb_image loops forever on a run of length 0
// and reads past the end of a flat file as zeros. The format is small.
absl::StatusOr<cv::Mat> ParseRgbe(absl::string_view bytes) {
  auto corrupt = [](absl::string_view why) {
    return absl::InvalidArgumentError(absl::StrCat("corrupt RGBE file: ", why));
  };
  if (!absl::StartsWith(bytes, "#?")) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a Radiance RGBE file: it starts ",
                     QuoteInput(bytes.substr(0, 16))));
  }
  // The header: lines up to an empty one, then the resolution line.
  constexpr size_t kMaxHeaderBytes = 64 * 1024;
  size_t at = 0;
  bool format = false;
  while (true) {
    const size_t newline = bytes.find('\n', at);
    if (newline == absl::string_view::npos || newline > kMaxHeaderBytes) {
      return corrupt(absl::StrCat("no end of the header in its first ",
                                  kMaxHeaderBytes, " bytes"));
    }
    const absl::string_view line = bytes.substr(at, newline - at);
    at = newline + 1;
    if (line.empty()) break;
    if (absl::StartsWith(line, "FORMAT=")) {
      if (line != "FORMAT=32-bit_rle_rgbe") {
        return corrupt(absl::StrCat("unsupported ", QuoteInput(line)));
      }
      format = true;
    }
  }
  if (!format) return corrupt("no FORMAT=32-bit_rle_rgbe in the header");
  const size_t newline = bytes.find('\n', at);
  const absl::string_view resolution =
      bytes.substr(at, newline == absl::string_view::npos ? 64 : newline - at);
  const std::vector<absl::string_view> parts =
      absl::StrSplit(resolution, ' ', absl::SkipEmpty());
  int64_t height = 0, width = 0;
  if (newline == absl::string_view::npos || parts.size() != 4 ||
      parts[0] != "-Y" || parts[2] != "+X" ||
      !absl::SimpleAtoi(parts[1], &height) ||
      !absl::SimpleAtoi(parts[3], &width)) {
    return corrupt(absl::StrCat("the resolution line is not \"-Y H +X W\": ",
                                QuoteInput(resolution)));
  }
  RETURN_IF_ERROR(ImageBytes("RGBE", width, height, 3, sizeof(float)).status());
  const absl::string_view data = bytes.substr(newline + 1);
  // The least a scanline takes: a run-length encoded one four 2-byte runs
  // of at most 127 pixels per channel after its 4-byte mark; a flat one 4
  // bytes a pixel. A file shorter than that for every scanline is refused
  // before the image is allocated.
  const bool encodable = width >= 8 && width <= 0x7fff;
  const int64_t least =
      encodable ? 4 + 4 * 2 * ((width + 126) / 127) : 4 * width;
  if (static_cast<int64_t>(data.size()) / height < least) {
    return corrupt(absl::StrCat("truncated: ", height, " scanlines of ", width,
                                " pixels need at least ", least * height,
                                " bytes, the file has ", data.size()));
  }
  cv::Mat rgbe(static_cast<int>(height), static_cast<int>(width), CV_8UC4);
  size_t pos = 0;
  auto next = [&](uint8_t* out) {
    if (pos >= data.size()) return false;
    *out = static_cast<uint8_t>(data[pos++]);
    return true;
  };
  bool flat = !encodable;
  for (int y = 0; y < rgbe.rows; ++y) {
    uint8_t* row = rgbe.ptr<uint8_t>(y);
    if (!flat) {
      uint8_t mark[4];
      for (uint8_t& m : mark) {
        if (!next(&m)) return corrupt(absl::StrCat("truncated at row ", y));
      }
      if (mark[0] != 2 || mark[1] != 2 || (mark[2] & 0x80) != 0) {
        // Not run-length encoded: as Ward's reader, the rest is flat, and
        // these four bytes are its first pixel.
        flat = true;
        pos -= 4;
      } else if (((mark[2] << 8) | mark[3]) != width) {
        return corrupt(absl::StrCat("row ", y, " has a scanline of ",
                                    (mark[2] << 8) | mark[3], " pixels, not ",
                                    width));
      }
    }
    if (flat) {
      if (data.size() - pos < static_cast<size_t>(4 * width)) {
        return corrupt(absl::StrCat("truncated at row ", y));
      }
      std::memcpy(row, data.data() + pos, 4 * width);
      pos += 4 * width;
      continue;
    }
    for (int channel = 0; channel < 4; ++channel) {
      for (int x = 0; x < width;) {
        uint8_t count = 0, value = 0;
        if (!next(&count)) return corrupt(absl::StrCat("truncated at row ", y));
        // Above 128: a run of count - 128 copies of the next byte; else
        // count bytes as they are.
        const bool run = count > 128;
        if (run) count -= 128;
        if (count == 0 || count > width - x) {
          return corrupt(absl::StrCat("row ", y, ": a run of ", int{count},
                                      " at pixel ", x, " of ", width));
        }
        for (const int end = x + count; x < end; ++x) {
          if ((!run || x == end - count) && !next(&value)) {
            return corrupt(absl::StrCat("truncated at row ", y));
          }
          row[4 * x + channel] = value;
        }
      }
    }
  }
  // RGBE to float as Ward's reader: mantissa x 2^(exponent - 136).
  cv::Mat bgr(rgbe.size(), CV_32FC3);
  for (int y = 0; y < rgbe.rows; ++y) {
    const uint8_t* in = rgbe.ptr<uint8_t>(y);
    float* out = bgr.ptr<float>(y);
    for (int x = 0; x < rgbe.cols; ++x, in += 4, out += 3) {
      const float f = in[3] == 0 ? 0.0f : std::ldexp(1.0f, in[3] - 136);
      out[0] = in[2] * f;
      out[1] = in[1] * f;
      out[2] = in[0] * f;
    }
  }
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
