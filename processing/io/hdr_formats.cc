// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/hdr_formats.h"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStdIO.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <exception>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
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

// Reads one whitespace-delimited token of a PFM header.
bool NextToken(absl::string_view data, size_t& at, std::string& token) {
  while (at < data.size() &&
         std::isspace(static_cast<unsigned char>(data[at]))) {
    ++at;
  }
  size_t start = at;
  while (at < data.size() &&
         !std::isspace(static_cast<unsigned char>(data[at]))) {
    ++at;
  }
  token = std::string(data.substr(start, at - start));
  return !token.empty();
}

uint32_t ByteSwap32(uint32_t v) {
  return (v >> 24) | ((v >> 8) & 0xFF00u) | ((v << 8) & 0xFF0000u) | (v << 24);
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

absl::StatusOr<cv::Mat> ReadPfm(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string bytes, ReadFileBytes(path));
  auto bad = [&](absl::string_view why) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt PFM ", path.string(), ": ", why));
  };
  size_t at = 0;
  std::string magic, w_s, h_s, scale_s;
  if (!NextToken(bytes, at, magic) || (magic != "PF" && magic != "Pf")) {
    return bad("missing PF/Pf magic");
  }
  int width = 0, height = 0;
  double scale = 0;
  if (!NextToken(bytes, at, w_s) || !NextToken(bytes, at, h_s) ||
      !NextToken(bytes, at, scale_s) || !absl::SimpleAtoi(w_s, &width) ||
      !absl::SimpleAtoi(h_s, &height) || !absl::SimpleAtod(scale_s, &scale) ||
      width <= 0 || height <= 0 || scale == 0) {
    return bad("bad header");
  }
  ++at;  // the single whitespace after the scale
  const int channels = magic == "PF" ? 3 : 1;
  const size_t row_bytes = sizeof(float) * size_t(width) * channels;
  if (bytes.size() < at || bytes.size() - at < row_bytes * height) {
    return bad(absl::StrCat("truncated: need ", row_bytes * height,
                            " bytes of pixels"));
  }
  const bool file_little = scale < 0;
  const bool swap = file_little != (std::endian::native == std::endian::little);
  cv::Mat img(height, width, CV_32FC(channels));
  for (int y = 0; y < height; ++y) {
    float* dst = img.ptr<float>(height - 1 - y);
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

absl::StatusOr<cv::Mat> ReadExr(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string bytes, ReadFileBytes(path));
  try {
    Imf::StdISStream stream;
    stream.str(bytes);
    Imf::InputFile file(stream);
    const Imath::Box2i dw = file.header().dataWindow();
    const int width = dw.max.x - dw.min.x + 1;
    const int height = dw.max.y - dw.min.y + 1;
    const Imf::ChannelList& list = file.header().channels();
    const bool grey =
        list.findChannel("Y") != nullptr && list.findChannel("R") == nullptr;
    const int channels = grey ? 1 : 3;
    cv::Mat rgb(height, width, CV_32FC(channels), cv::Scalar::all(0));
    const size_t xs = sizeof(float) * channels;
    const size_t ys = xs * width;
    char* base =
        reinterpret_cast<char*>(rgb.data) - (dw.min.x * xs + dw.min.y * ys);
    Imf::FrameBuffer fb;
    const char* const kNames[3] = {"R", "G", "B"};
    for (int c = 0; c < channels; ++c) {
      fb.insert(
          grey ? "Y" : kNames[c],
          Imf::Slice(Imf::FLOAT, base + sizeof(float) * c, xs, ys, 1, 1, 0.0));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    if (channels == 3) cv::cvtColor(rgb, rgb, cv::COLOR_RGB2BGR);
    return rgb;
  } catch (const std::exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot read EXR ", path.string(), ": ", e.what()));
  }
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

absl::StatusOr<cv::Mat> ReadRgbe(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string bytes, ReadFileBytes(path));
  if (bytes.rfind("#?", 0) != 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("not a Radiance RGBE file: ", path.string()));
  }
  cv::Mat img;
  try {
    std::vector<uchar> buf(bytes.begin(), bytes.end());
    img = cv::imdecode(buf, cv::IMREAD_ANYDEPTH | cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("cannot decode RGBE ", path.string(), ": ", e.what()));
  }
  if (img.empty() || img.depth() != CV_32F) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt RGBE file ", path.string()));
  }
  return img;
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
