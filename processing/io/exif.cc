// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/exif.h"

#include <cstdint>
#include <cstring>

namespace hdrstereo::io {
namespace {

class TiffReader {
 public:
  explicit TiffReader(absl::string_view data) : data_(data) {
    if (data_.size() >= 8 && data_.substr(0, 2) == "MM") big_endian_ = true;
  }
  bool Valid() const {
    if (data_.size() < 8) return false;
    return (data_.substr(0, 2) == "II" || data_.substr(0, 2) == "MM") &&
           U16(2) == 42;
  }
  uint32_t U16(size_t off) const {
    if (off + 2 > data_.size()) return 0;
    const auto* p = reinterpret_cast<const unsigned char*>(data_.data() + off);
    return big_endian_ ? (p[0] << 8 | p[1]) : (p[1] << 8 | p[0]);
  }
  uint32_t U32(size_t off) const {
    if (off + 4 > data_.size()) return 0;
    return big_endian_ ? (U16(off) << 16 | U16(off + 2))
                       : (U16(off + 2) << 16 | U16(off));
  }
  size_t size() const { return data_.size(); }
  absl::string_view data() const { return data_; }

 private:
  absl::string_view data_;
  bool big_endian_ = false;
};

constexpr uint16_t kTypeAscii = 2;
constexpr uint16_t kTypeShort = 3;
constexpr uint16_t kTypeLong = 4;
constexpr uint16_t kTypeRational = 5;

struct Entry {
  uint16_t tag;
  uint16_t type;
  uint32_t count;
  size_t value_offset;  // where the value lies (inline or pointed to)
};

std::optional<double> EntryNumber(const TiffReader& r, const Entry& e) {
  switch (e.type) {
    case kTypeShort:
      return r.U16(e.value_offset);
    case kTypeLong:
      return r.U32(e.value_offset);
    case kTypeRational: {
      uint32_t num = r.U32(e.value_offset);
      uint32_t den = r.U32(e.value_offset + 4);
      if (den == 0) return std::nullopt;
      return static_cast<double>(num) / den;
    }
    default:
      return std::nullopt;
  }
}

std::string EntryString(const TiffReader& r, const Entry& e) {
  if (e.type != kTypeAscii || e.value_offset + e.count > r.size()) return "";
  std::string s(r.data().substr(e.value_offset, e.count));
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  return s;
}

void ReadIfd(const TiffReader& r, size_t ifd, ExifInfo& info, int depth) {
  if (depth > 2 || ifd == 0 || ifd + 2 > r.size()) return;
  uint32_t n = r.U16(ifd);
  std::string make, model;
  for (uint32_t i = 0; i < n && i < 1000; ++i) {
    size_t at = ifd + 2 + 12 * i;
    if (at + 12 > r.size()) break;
    Entry e{static_cast<uint16_t>(r.U16(at)),
            static_cast<uint16_t>(r.U16(at + 2)), r.U32(at + 4), at + 8};
    size_t unit = e.type == kTypeShort      ? 2
                  : e.type == kTypeRational ? 8
                  : e.type == kTypeLong     ? 4
                                            : 1;
    if (unit * e.count > 4) e.value_offset = r.U32(at + 8);
    switch (e.tag) {
      case 0x010F:
        make = EntryString(r, e);
        break;
      case 0x0110:
        model = EntryString(r, e);
        break;
      case 0x8769:  // Exif sub-IFD
        if (auto off = EntryNumber(r, e)) {
          ReadIfd(r, static_cast<size_t>(*off), info, depth + 1);
        }
        break;
      case 0x829A:
        info.exposure_s = EntryNumber(r, e);
        break;
      case 0x829D:
        info.aperture = EntryNumber(r, e);
        break;
      case 0x8827:
        info.iso = EntryNumber(r, e);
        break;
      default:
        break;
    }
  }
  if (!make.empty() || !model.empty()) {
    info.camera = make.empty()    ? model
                  : model.empty() ? make
                                  : make + " " + model;
  }
}

uint32_t BigEndian32(absl::string_view s, size_t off) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data() + off);
  return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 |
         p[3];
}

}  // namespace

ExifInfo ParseExifTiff(absl::string_view tiff) {
  ExifInfo info;
  TiffReader r(tiff);
  if (!r.Valid()) return info;
  ReadIfd(r, r.U32(4), info, 0);
  return info;
}

ExifInfo ParseExifFromFile(absl::string_view f) {
  if (f.size() >= 4 && (f.substr(0, 4) == absl::string_view("II*\0", 4) ||
                        f.substr(0, 4) == absl::string_view("MM\0*", 4))) {
    return ParseExifTiff(f);
  }
  if (f.size() >= 2 && static_cast<unsigned char>(f[0]) == 0xFF &&
      static_cast<unsigned char>(f[1]) == 0xD8) {  // JPEG
    size_t at = 2;
    while (at + 4 <= f.size() && static_cast<unsigned char>(f[at]) == 0xFF) {
      unsigned char marker = static_cast<unsigned char>(f[at + 1]);
      size_t len = (static_cast<unsigned char>(f[at + 2]) << 8) |
                   static_cast<unsigned char>(f[at + 3]);
      if (marker == 0xDA || len < 2) break;  // start of scan
      if (marker == 0xE1 && at + 4 + len - 2 <= f.size()) {
        absl::string_view seg = f.substr(at + 4, len - 2);
        if (seg.size() > 6 &&
            seg.substr(0, 6) == absl::string_view("Exif\0\0", 6)) {
          return ParseExifTiff(seg.substr(6));
        }
      }
      at += 2 + len;
    }
    return {};
  }
  if (f.size() >= 8 && f.substr(1, 3) == "PNG") {
    size_t at = 8;
    while (at + 12 <= f.size()) {
      uint32_t len = BigEndian32(f, at);
      absl::string_view type = f.substr(at + 4, 4);
      if (at + 12 + len > f.size()) break;
      if (type == "eXIf") return ParseExifTiff(f.substr(at + 8, len));
      if (type == "IEND") break;
      at += 12 + len;
    }
  }
  return {};
}

}  // namespace hdrstereo::io
