// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/exif.h"

#include <libraw/libraw.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/civil_time.h"
#include "absl/time/time.h"

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
  // True when `length` bytes from `offset` lie within the data.
  bool Fits(size_t offset, size_t length) const {
    return offset <= data_.size() && length <= data_.size() - offset;
  }
  uint32_t U16(size_t off) const {
    if (!Fits(off, 2)) return 0;
    const auto* p = reinterpret_cast<const unsigned char*>(data_.data() + off);
    return big_endian_ ? (p[0] << 8 | p[1]) : (p[1] << 8 | p[0]);
  }
  uint32_t U32(size_t off) const {
    if (!Fits(off, 4)) return 0;
    return big_endian_ ? (U16(off) << 16 | U16(off + 2))
                       : (U16(off + 2) << 16 | U16(off));
  }
  absl::string_view data() const { return data_; }

 private:
  absl::string_view data_;
  bool big_endian_ = false;
};

constexpr uint16_t kTypeAscii = 2;
constexpr uint16_t kTypeShort = 3;
constexpr uint16_t kTypeLong = 4;
constexpr uint16_t kTypeRational = 5;

// Bytes of one value of a TIFF field type; 0 for types TIFF 6.0 does not
// define.
size_t TypeSize(uint16_t type) {
  switch (type) {
    case 1:  // BYTE
    case kTypeAscii:
    case 6:  // SBYTE
    case 7:  // UNDEFINED
      return 1;
    case kTypeShort:
    case 8:  // SSHORT
      return 2;
    case kTypeLong:
    case 9:   // SLONG
    case 11:  // FLOAT
      return 4;
    case kTypeRational:
    case 10:  // SRATIONAL
    case 12:  // DOUBLE
      return 8;
    default:
      return 0;
  }
}

// Entries read of one IFD, and strings kept of a field: cameras write a few
// dozen entries and strings of a few dozen characters.
constexpr uint32_t kMaxIfdEntries = 1000;
constexpr size_t kMaxExifString = 255;
// ISOSpeedRatings (0x8827) is a SHORT: EXIF 2.3 writes 65535 there for a
// higher ISO.
constexpr uint32_t kSaturatedIso = 65535;

// An IFD entry whose count x type-size bytes of value lie within the data.
struct Entry {
  uint16_t tag;
  uint16_t type;
  uint32_t count;
  size_t value_offset;  // where the value lies (inline or pointed to)
};

// The entry at `at` (12 bytes within the data); nullopt when its type is
// unknown or its value does not lie within the data.
std::optional<Entry> ReadEntry(const TiffReader& r, size_t at) {
  Entry e{static_cast<uint16_t>(r.U16(at)),
          static_cast<uint16_t>(r.U16(at + 2)), r.U32(at + 4), at + 8};
  const size_t unit = TypeSize(e.type);
  if (unit == 0 || e.count > r.data().size() / unit) return std::nullopt;
  const size_t bytes = unit * e.count;  // no overflow: at most the data size
  if (bytes > 4) e.value_offset = r.U32(at + 8);
  if (!r.Fits(e.value_offset, bytes)) return std::nullopt;
  return e;
}

// The entry's first value as a number (SHORT, LONG or RATIONAL).
std::optional<double> EntryNumber(const TiffReader& r, const Entry& e) {
  if (e.count == 0) return std::nullopt;
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

// An ASCII value up to its first NUL, at most kMaxExifString bytes, without
// trailing spaces.
std::string EntryString(const TiffReader& r, const Entry& e) {
  if (e.type != kTypeAscii) return "";
  absl::string_view s = r.data().substr(e.value_offset, e.count);
  s = s.substr(0, std::min(s.find('\0'), kMaxExifString));
  while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
  return std::string(s);
}

// What IFD0 and the Exif IFD hold, before the ISO is chosen.
struct Fields {
  std::string make, model;
  size_t exif_ifd = 0;
  std::optional<double> iso;  // ISOSpeedRatings (0x8827)
  std::optional<double> sensitivity_type;
  std::optional<double> sos, rei, iso_speed;
};

// Reads the entries of the IFD at `ifd` (at most kMaxIfdEntries).
void ReadIfd(const TiffReader& r, size_t ifd, Fields& fields, ExifInfo& info) {
  if (ifd == 0 || !r.Fits(ifd, 2)) return;
  const uint32_t n = std::min(r.U16(ifd), kMaxIfdEntries);
  for (uint32_t i = 0; i < n && r.Fits(ifd + 2 + 12 * i, 12); ++i) {
    const std::optional<Entry> e = ReadEntry(r, ifd + 2 + 12 * i);
    if (!e.has_value()) continue;
    switch (e->tag) {
      case 0x010F:
        fields.make = EntryString(r, *e);
        break;
      case 0x0110:
        fields.model = EntryString(r, *e);
        break;
      case 0x8769:  // Exif sub-IFD
        fields.exif_ifd = static_cast<size_t>(EntryNumber(r, *e).value_or(0));
        break;
      case 0x829A:
        info.exposure_s = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x829D:
        info.aperture = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x8827:
        fields.iso = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x8830:
        fields.sensitivity_type = EntryNumber(r, *e);
        break;
      case 0x8831:
        fields.sos = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x8832:
        fields.rei = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x8833:
        fields.iso_speed = PositiveFinite(EntryNumber(r, *e));
        break;
      case 0x9003:
        info.date_time_original = EntryString(r, *e);
        break;
      case 0x9291:
        info.subsec_time_original = EntryString(r, *e);
        break;
      default:
        break;
    }
  }
}

// ISOSpeedRatings, unless it is missing or saturated (EXIF 2.3): then the
// 32-bit sensitivity SensitivityType names (0x8830: 1 SOS, 2 REI, 3 ISO
// speed, 4 to 7 their combinations, 0 or missing unknown), in the order
// RecommendedExposureIndex, ISOSpeed, StandardOutputSensitivity.
std::optional<double> ChooseIso(const Fields& f) {
  if (f.iso.has_value() && *f.iso < kSaturatedIso) return f.iso;
  constexpr int kSos = 1, kRei = 2, kIsoSpeed = 4;
  // The sensitivities each SensitivityType names.
  static constexpr int kNamed[8] = {kSos | kRei | kIsoSpeed,
                                    kSos,
                                    kRei,
                                    kIsoSpeed,
                                    kSos | kRei,
                                    kSos | kIsoSpeed,
                                    kRei | kIsoSpeed,
                                    kSos | kRei | kIsoSpeed};
  const double type = f.sensitivity_type.value_or(0);
  const int named =
      type >= 0 && type < 8 ? kNamed[static_cast<int>(type)] : kNamed[0];
  if ((named & kRei) && f.rei.has_value()) return f.rei;
  if ((named & kIsoSpeed) && f.iso_speed.has_value()) return f.iso_speed;
  if ((named & kSos) && f.sos.has_value()) return f.sos;
  return f.iso;
}

uint32_t BigEndian32(absl::string_view s, size_t off) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data() + off);
  return uint32_t{p[0]} << 24 | uint32_t{p[1]} << 16 | uint32_t{p[2]} << 8 |
         p[3];
}

// Little-endian TIFF building blocks for EncodeExifTiff.
class TiffWriter {
 public:
  struct Field {
    uint16_t tag;
    uint16_t type;
    uint32_t count;
    std::string value;  // the value's bytes, little-endian
  };

  static std::string U16(uint32_t v) {
    return {static_cast<char>(v & 0xFF), static_cast<char>((v >> 8) & 0xFF)};
  }
  static std::string U32(uint32_t v) { return U16(v & 0xFFFF) + U16(v >> 16); }
  static Field Ascii(uint16_t tag, const std::string& text) {
    std::string value = text + '\0';
    return {tag, kTypeAscii, static_cast<uint32_t>(value.size()), value};
  }
  static Field Short(uint16_t tag, uint32_t v) {
    return {tag, kTypeShort, 1, U16(v)};
  }
  static Field Long(uint16_t tag, uint32_t v) {
    return {tag, kTypeLong, 1, U32(v)};
  }
  static Field Rational(uint16_t tag, uint32_t num, uint32_t den) {
    return {tag, kTypeRational, 1, U32(num) + U32(den)};
  }

  // Appends an IFD (fields sorted by tag) at the end of `out`, values that
  // do not fit in 4 bytes right after it; returns the IFD's offset.
  static uint32_t AppendIfd(std::string& out,
                            const std::vector<Field>& fields) {
    const uint32_t at = static_cast<uint32_t>(out.size());
    uint32_t data = at + 2 + 12 * static_cast<uint32_t>(fields.size()) + 4;
    std::string entries = U16(static_cast<uint32_t>(fields.size()));
    std::string blob;
    for (const Field& f : fields) {
      entries += U16(f.tag) + U16(f.type) + U32(f.count);
      if (f.value.size() <= 4) {
        entries += f.value + std::string(4 - f.value.size(), '\0');
      } else {
        entries += U32(data + static_cast<uint32_t>(blob.size()));
        blob += f.value;
        if (blob.size() % 2 != 0) blob.push_back('\0');
      }
    }
    entries += U32(0);  // no next IFD
    out += entries + blob;
    return at;
  }
};

// ExposureTime as a rational: 1/n when the time is (nearly) such a fraction,
// as cameras write it, else micro-seconds.
std::pair<uint32_t, uint32_t> ExposureRational(double seconds) {
  if (seconds > 0 && seconds < 1) {
    const double n = std::round(1.0 / seconds);
    if (std::abs(1.0 / n - seconds) < 1e-9 * seconds + 1e-12) {
      return {1, static_cast<uint32_t>(n)};
    }
  }
  return {static_cast<uint32_t>(std::llround(seconds * 1e6)), 1000000};
}

}  // namespace

std::optional<double> PositiveFinite(std::optional<double> value) {
  if (value.has_value() && std::isfinite(*value) && *value > 0) return value;
  return std::nullopt;
}

std::optional<int64_t> ExifCaptureTimeMs(const ExifInfo& info) {
  const std::string& t = info.date_time_original;
  int y, mo, d, h, mi, s;
  if (t.size() < 19 || std::sscanf(t.c_str(), "%4d:%2d:%2d %2d:%2d:%2d", &y,
                                   &mo, &d, &h, &mi, &s) != 6) {
    return std::nullopt;
  }
  const absl::CivilSecond civil(y, mo, d, h, mi, s);
  if (civil.year() != y || civil.month() != mo || civil.day() != d ||
      civil.hour() != h || civil.minute() != mi || civil.second() != s) {
    return std::nullopt;  // e.g. month 13, or a blank "    :  :  " stamp
  }
  int64_t ms = absl::ToUnixMillis(absl::FromCivil(civil, absl::UTCTimeZone()));
  // SubSecTimeOriginal is decimal digits of a fraction: "5" = 0.5 s.
  const std::string& sub = info.subsec_time_original;
  if (!sub.empty() && sub.size() <= 9 &&
      sub.find_first_not_of("0123456789") == std::string::npos) {
    ms += static_cast<int64_t>(std::stoll(sub) *
                               std::pow(10.0, 3.0 - sub.size()));
  }
  return ms;
}

ExifInfo ReadRawMetadata(absl::string_view file_bytes) {
  // Most RAW formats (DNG, CR2, NEF, ARW, PEF, ...) are TIFF structures: read
  // their EXIF directly. LibRaw reports a missing exposure or aperture as 1,
  // indistinguishable from a real 1 s or f/1, so it is only asked about the
  // others (CR3, RAF, ...).
  ExifInfo info = ParseExifFromFile(file_bytes);
  if (TiffReader(file_bytes).Valid()) return info;
  auto raw = std::make_unique<LibRaw>();
  // LibRaw only reads the buffer; its signature is not const.
  if (raw->open_buffer(const_cast<char*>(file_bytes.data()),
                       file_bytes.size()) != LIBRAW_SUCCESS) {
    return info;
  }
  const libraw_imgother_t& other = raw->imgdata.other;
  // LibRaw passes on what the file says: 0, a negative number, NaN or
  // infinity leave the field as the EXIF had it.
  if (auto v = PositiveFinite(other.shutter)) info.exposure_s = v;
  if (auto v = PositiveFinite(other.iso_speed)) info.iso = v;
  if (auto v = PositiveFinite(other.aperture)) info.aperture = v;
  const std::string make = raw->imgdata.idata.make;
  const std::string model = raw->imgdata.idata.model;
  info.camera = make.empty()    ? model
                : model.empty() ? make
                                : make + " " + model;
  if (other.timestamp > 0) {
    info.date_time_original =
        absl::FormatTime("%Y:%m:%d %H:%M:%S", absl::FromTimeT(other.timestamp),
                         absl::UTCTimeZone());
  }
  return info;
}

std::string EncodeExifTiff(const ExifInfo& info) {
  using W = TiffWriter;
  std::vector<W::Field> exif;
  if (info.exposure_s.has_value()) {
    const auto [num, den] = ExposureRational(*info.exposure_s);
    exif.push_back(W::Rational(0x829A, num, den));
  }
  if (info.aperture.has_value()) {
    exif.push_back(W::Rational(
        0x829D, static_cast<uint32_t>(std::llround(*info.aperture * 100)),
        100));
  }
  if (info.iso.has_value()) {
    // As cameras write an ISO above ISOSpeedRatings' 16 bits (EXIF 2.3):
    // 65535 there, the ISO as RecommendedExposureIndex (SensitivityType 2).
    const uint32_t iso = static_cast<uint32_t>(std::lround(*info.iso));
    exif.push_back(W::Short(0x8827, std::min<uint32_t>(iso, kSaturatedIso)));
    if (iso > kSaturatedIso) {
      exif.push_back(W::Short(0x8830, 2));
      exif.push_back(W::Long(0x8832, iso));
    }
  }
  if (!info.date_time_original.empty()) {
    exif.push_back(W::Ascii(0x9003, info.date_time_original));
  }
  if (!info.subsec_time_original.empty()) {
    exif.push_back(W::Ascii(0x9291, info.subsec_time_original));
  }
  // IFD0 first (Model, then the pointer to the Exif IFD that follows it).
  std::string out = "II" + W::U16(42) + W::U32(8);
  std::vector<W::Field> ifd0;
  if (!info.camera.empty()) ifd0.push_back(W::Ascii(0x0110, info.camera));
  ifd0.push_back(W::Long(0x8769, 0));  // patched below
  W::AppendIfd(out, ifd0);
  const uint32_t exif_at = W::AppendIfd(out, exif);
  // The pointer is the last entry of IFD0: 8 + 2 + 12 * (n - 1) + 8.
  const size_t pointer_at = 8 + 2 + 12 * (ifd0.size() - 1) + 8;
  out.replace(pointer_at, 4, W::U32(exif_at));
  return out;
}

absl::StatusOr<std::string> EmbedExif(absl::string_view f,
                                      absl::string_view exif_tiff) {
  if (f.size() >= 2 && static_cast<unsigned char>(f[0]) == 0xFF &&
      static_cast<unsigned char>(f[1]) == 0xD8) {
    const size_t length = 2 + 6 + exif_tiff.size();
    if (length > 0xFFFF) {
      return absl::InvalidArgumentError(
          absl::StrCat("an EXIF block of ", exif_tiff.size(),
                       " bytes does not fit in a JPEG APP1 segment"));
    }
    std::string out(f.substr(0, 2));
    out += "\xFF\xE1";
    out.push_back(static_cast<char>(length >> 8));
    out.push_back(static_cast<char>(length & 0xFF));
    absl::StrAppend(&out, absl::string_view("Exif\0\0", 6), exif_tiff,
                    f.substr(2));
    return out;
  }
  constexpr size_t kIhdrEnd = 8 + 4 + 4 + 13 + 4;  // signature + IHDR chunk
  if (f.size() >= kIhdrEnd && f.substr(1, 3) == "PNG" &&
      f.substr(12, 4) == "IHDR") {
    const std::string chunk = absl::StrCat("eXIf", exif_tiff);
    const uLong crc = crc32(0L, reinterpret_cast<const Bytef*>(chunk.data()),
                            static_cast<uInt>(chunk.size()));
    auto be32 = [](uint32_t v) {
      return std::string{
          static_cast<char>(v >> 24), static_cast<char>((v >> 16) & 0xFF),
          static_cast<char>((v >> 8) & 0xFF), static_cast<char>(v & 0xFF)};
    };
    return absl::StrCat(f.substr(0, kIhdrEnd),
                        be32(static_cast<uint32_t>(exif_tiff.size())), chunk,
                        be32(static_cast<uint32_t>(crc)), f.substr(kIhdrEnd));
  }
  return absl::InvalidArgumentError(
      "EXIF can be added to PNG and JPEG files only");
}

ExifInfo ParseExifTiff(absl::string_view tiff) {
  ExifInfo info;
  TiffReader r(tiff);
  if (!r.Valid()) return info;
  // IFD0 and the Exif IFD it points to, no other: two IFDs at most.
  Fields fields;
  const size_t ifd0 = r.U32(4);
  ReadIfd(r, ifd0, fields, info);
  if (fields.exif_ifd != ifd0) ReadIfd(r, fields.exif_ifd, fields, info);
  info.iso = ChooseIso(fields);
  info.camera = fields.make.empty()    ? fields.model
                : fields.model.empty() ? fields.make
                                       : fields.make + " " + fields.model;
  return info;
}

ExifInfo ParseExifFromFile(absl::string_view f) {
  if (f.size() >= 4 && (f.substr(0, 4) == absl::string_view("II*\0", 4) ||
                        f.substr(0, 4) == absl::string_view("MM\0*", 4))) {
    return ParseExifTiff(f);
  }
  auto byte = [&](size_t at) { return static_cast<unsigned char>(f[at]); };
  if (f.size() >= 2 && byte(0) == 0xFF && byte(1) == 0xD8) {  // JPEG
    // Marker segments: FF, marker, 2-byte length (counting itself), data.
    size_t at = 2;
    while (f.size() - at >= 4 && byte(at) == 0xFF) {
      const unsigned char marker = byte(at + 1);
      const size_t len = byte(at + 2) << 8 | byte(at + 3);
      if (marker == 0xDA || len < 2) break;    // start of scan
      if (len - 2 > f.size() - at - 4) break;  // the segment runs off
      const absl::string_view segment = f.substr(at + 4, len - 2);
      if (marker == 0xE1 &&
          absl::StartsWith(segment, absl::string_view("Exif\0\0", 6))) {
        return ParseExifTiff(segment.substr(6));
      }
      at += 2 + len;
    }
    return {};
  }
  if (f.size() >= 8 && f.substr(1, 3) == "PNG") {
    // Chunks: 4-byte length (below 2^31), type, data, CRC.
    size_t at = 8;
    while (f.size() - at >= 12) {
      const uint32_t len = BigEndian32(f, at);
      if (len > 0x7FFFFFFF || len > f.size() - at - 12) break;
      const absl::string_view type = f.substr(at + 4, 4);
      if (type == "eXIf") return ParseExifTiff(f.substr(at + 8, len));
      if (type == "IEND") break;
      at += 12 + len;
    }
  }
  return {};
}

}  // namespace hdrstereo::io
