#include "mountcal/io/las.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <exception>
#include <random>
#include <stdexcept>
#include <thread>

#include "io/bytes.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal::io {

namespace {

using bytes::get;
using bytes::put;

std::string fixedString(const char* buf, std::size_t off, std::size_t n) {
  std::string s(buf + off, n);
  return s.substr(0, s.find('\0'));
}
void putString(char* buf, std::size_t off, std::size_t n, const std::string& s) {
  std::memset(buf + off, 0, n);
  std::memcpy(buf + off, s.data(), std::min(n, s.size()));
}
std::string byteAt(std::uint64_t b) { return "byte " + std::to_string(b); }

constexpr std::size_t kVlrHeader = 54, kEvlrHeader = 60;

std::uint16_t headerSize(std::uint8_t minor) { return minor >= 4 ? 375 : minor == 3 ? 235 : 227; }

}  // namespace

std::uint16_t LasHeader::standardRecordLength(std::uint8_t f) {
  static const std::uint16_t kLength[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return f <= 10 ? kLength[f] : 0;
}

double scanAngleDeg(const LasHeader& h, const LasPoint& p) {
  return h.point_format >= 6 ? p.scan_angle * 0.006 : static_cast<double>(p.scan_angle);
}

void setScanAngleDeg(const LasHeader& h, double deg, LasPoint* p) {
  if (h.point_format >= 6) {
    const double units = std::round(std::clamp(deg, -180.0, 180.0) / 0.006);
    p->scan_angle = static_cast<std::int16_t>(std::clamp(units, -30000.0, 30000.0));
  } else {
    p->scan_angle = static_cast<std::int16_t>(std::clamp(std::round(deg), -90.0, 90.0));
  }
}

// ------------------------------------------------------------------------------------------
/// A LAZ file's decoding state: chunks are decoded a few at a time (one per core).
struct LasReader::Laz {
  LazVlr vlr;
  std::vector<LazChunk> chunks;
  std::size_t next_chunk = 0;
  std::vector<std::uint8_t> decoded;  // records of the chunks decoded last
  std::size_t decoded_points = 0, position = 0;
};

namespace {
constexpr std::uint64_t kMaxChunkRecordBytes = 256ull << 20;  // a decoded chunk must fit in this
unsigned decodeThreads() {                                    // hardware_concurrency() reads /sys on every call: once is enough
  static const unsigned n = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
  return n;
}
}  // namespace

LasReader::~LasReader() = default;
const LazVlr* LasReader::laz() const { return laz_ ? &laz_->vlr : nullptr; }
const std::vector<LazChunk>& LasReader::lazChunks() const {
  static const std::vector<LazChunk> none;
  return laz_ ? laz_->chunks : none;
}

namespace {

/// What the header block says of the rest of the file.
struct HeaderBlock {
  std::uint16_t header_size = 0;
  std::uint32_t vlr_count = 0;
  std::uint64_t evlr_start = 0;
  std::uint32_t evlr_count = 0;
  bool compressed = false;  // the point format's LAZ bit
};

/// The public header block (LAS 1.4 R15 table 3) into `header`, checked against the file size.
HeaderBlock readHeaderBlock(std::ifstream& in, const std::string& path, std::uint64_t file_size, LasHeader* header_out,
                            std::uint64_t* point_offset_out) {
  LasHeader& header = *header_out;
  std::uint64_t& point_offset = *point_offset_out;
  HeaderBlock block;
  char h[375] = {};
  if (file_size < 227)
    throw FileError(path, byteAt(file_size),
                    "truncated LAS header (" + std::to_string(file_size) + " bytes; a LAS header has at least 227)");
  in.read(h, 227);
  if (std::memcmp(h, "LASF", 4) != 0) throw FileError(path, byteAt(0), "not a LAS file (signature is not 'LASF')");
  header.file_source_id = get<std::uint16_t>(h, 4);
  header.global_encoding = get<std::uint16_t>(h, 6);
  std::memcpy(header.project_guid.data(), h + 8, 16);
  header.version_major = get<std::uint8_t>(h, 24);
  header.version_minor = get<std::uint8_t>(h, 25);
  if (header.version_major != 1 || header.version_minor > 4) {
    throw FileError(path, byteAt(24),
                    "unsupported LAS version " + std::to_string(header.version_major) + "." + std::to_string(header.version_minor) +
                        " (1.0-1.4 are read)");
  }
  header.system_identifier = fixedString(h, 26, 32);
  header.generating_software = fixedString(h, 58, 32);
  header.creation_day = get<std::uint16_t>(h, 90);
  header.creation_year = get<std::uint16_t>(h, 92);
  block.header_size = get<std::uint16_t>(h, 94);
  const std::uint16_t header_size = block.header_size;
  point_offset = get<std::uint32_t>(h, 96);
  block.vlr_count = get<std::uint32_t>(h, 100);
  const std::uint8_t raw_format = get<std::uint8_t>(h, 104);
  block.compressed = (raw_format & 0xC0) != 0;  // bit 7 (bit 6 in old LASzip files): LAZ
  header.point_format = raw_format & 0x3F;
  header.point_record_length = get<std::uint16_t>(h, 105);
  std::uint64_t count = get<std::uint32_t>(h, 107);
  for (int r = 0; r < 5; ++r) header.points_by_return[r] = get<std::uint32_t>(h, 111 + 4 * r);
  for (int a = 0; a < 3; ++a) {
    header.scale[a] = get<double>(h, 131 + 8 * a);
    header.offset[a] = get<double>(h, 155 + 8 * a);
    header.max[a] = get<double>(h, 179 + 16 * a);
    header.min[a] = get<double>(h, 187 + 16 * a);
  }
  if (point_offset > file_size) {
    throw FileError(path, byteAt(96),
                    "offset to point data " + std::to_string(point_offset) + " is beyond the end of the file (" +
                        std::to_string(file_size) + " bytes)");
  }
  const std::uint16_t expected_header = headerSize(header.version_minor);
  if (header_size < std::min<std::uint16_t>(expected_header, 227) || header_size > file_size) {
    throw FileError(path, byteAt(94),
                    "header size " + std::to_string(header_size) + " is invalid for LAS 1." + std::to_string(header.version_minor));
  }
  if (point_offset < header_size) {  // the points would be read from the header's own bytes
    throw FileError(
        path, byteAt(96),
        "offset to point data " + std::to_string(point_offset) + " lies inside the header (" + std::to_string(header_size) + " bytes)");
  }
  if (header.version_minor >= 4 && header_size >= 375) {
    in.read(h + 227, 375 - 227);
    block.evlr_start = get<std::uint64_t>(h, 235);
    block.evlr_count = get<std::uint32_t>(h, 243);
    const std::uint64_t count14 = get<std::uint64_t>(h, 247);
    if (count14 != 0 || count == 0) count = count14;
    for (int r = 0; r < 15; ++r) header.points_by_return[r] = get<std::uint64_t>(h, 255 + 8 * r);
  }
  header.point_count = count;
  const std::uint16_t std_len = LasHeader::standardRecordLength(header.point_format);
  if (std_len == 0 || header.point_format == 4 || header.point_format == 5 || header.point_format >= 9) {
    throw FileError(path, byteAt(104),
                    "point data record format " + std::to_string(header.point_format) + " is not supported (0-3 and 6-8 are)");
  }
  if (header.point_record_length < std_len) {
    throw FileError(path, byteAt(105),
                    "point record length " + std::to_string(header.point_record_length) + " is shorter than format " +
                        std::to_string(header.point_format) + " needs (" + std::to_string(std_len) + ")");
  }
  for (int a = 0; a < 3; ++a) {
    if (!(header.scale[a] > 0) || !std::isfinite(header.scale[a]) || !std::isfinite(header.offset[a])) {
      throw FileError(path, byteAt(131 + 8 * a), "invalid scale or offset");
    }
  }
  // Bytes after the standard header block (user-defined header data).
  in.seekg(0);
  std::vector<char> head(header_size);
  in.read(head.data(), header_size);
  const std::uint16_t known = std::min<std::uint16_t>(header_size, expected_header);
  header.header_padding.assign(head.begin() + known, head.end());
  return block;
}

/// The VLRs into `header` (the LASzip VLR left out and returned, parsed; null for LAS) and the
/// bytes between the last VLR and the point data.
std::unique_ptr<LazVlr> readVlrs(std::ifstream& in, const std::string& path, std::uint16_t header_size, std::uint32_t vlr_count,
                                 std::uint64_t point_offset, LasHeader* header_out) {
  LasHeader& header = *header_out;
  std::unique_ptr<LazVlr> laszip;
  std::uint64_t pos = header_size;
  for (std::uint32_t v = 0; v < vlr_count; ++v) {
    if (pos + kVlrHeader > point_offset)
      throw FileError(
          path, byteAt(pos),
          "VLR " + std::to_string(v) + " runs into the point data (offset to point data is " + std::to_string(point_offset) + ")");
    char vh[kVlrHeader];
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(vh, kVlrHeader);
    LasVlr vlr;
    vlr.user_id = fixedString(vh, 2, 16);
    vlr.record_id = get<std::uint16_t>(vh, 18);
    const std::uint16_t len = get<std::uint16_t>(vh, 20);
    vlr.description = fixedString(vh, 22, 32);
    if (pos + kVlrHeader + len > point_offset)
      throw FileError(path, byteAt(pos),
                      "VLR " + std::to_string(v) + " (" + vlr.user_id + ") is longer than the space before the point data");
    vlr.data.resize(len);
    in.read(reinterpret_cast<char*>(vlr.data.data()), len);
    if (vlr.user_id == kLazVlrUserId && vlr.record_id == kLazVlrRecordId) {
      // The LASzip VLR describes the compression; it is not part of the LAS content.
      if (laszip) throw FileError(path, byteAt(pos), "a second LASzip VLR");
      laszip = std::make_unique<LazVlr>(parseLazVlr(vlr.data, header.point_format, header.point_record_length, path));
    } else {
      header.vlrs.push_back(std::move(vlr));
    }
    pos += kVlrHeader + len;
  }
  if (pos < point_offset) {
    header.vlr_padding.resize(point_offset - pos);
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(reinterpret_cast<char*>(header.vlr_padding.data()), static_cast<std::streamsize>(header.vlr_padding.size()));
  }
  return laszip;
}

/// The EVLRs (LAS 1.4) into `header`, each checked to lie within the file.
void readEvlrs(std::ifstream& in, const std::string& path, std::uint64_t evlr_start, std::uint32_t evlr_count, std::uint64_t file_size,
               LasHeader* header_out) {
  LasHeader& header = *header_out;
  std::uint64_t pos = evlr_start;
  for (std::uint32_t v = 0; v < evlr_count; ++v) {
    if (pos + kEvlrHeader > file_size) throw FileError(path, byteAt(pos), "EVLR " + std::to_string(v) + " is truncated");
    char vh[kEvlrHeader];
    in.seekg(static_cast<std::streamoff>(pos));
    in.read(vh, kEvlrHeader);
    LasVlr vlr;
    vlr.user_id = fixedString(vh, 2, 16);
    vlr.record_id = get<std::uint16_t>(vh, 18);
    const std::uint64_t len = get<std::uint64_t>(vh, 20);
    vlr.description = fixedString(vh, 28, 32);
    if (len > file_size - pos - kEvlrHeader) throw FileError(path, byteAt(pos), "EVLR " + std::to_string(v) + " is longer than the file");
    vlr.data.resize(len);
    in.read(reinterpret_cast<char*>(vlr.data.data()), static_cast<std::streamsize>(len));
    header.evlrs.push_back(std::move(vlr));
    pos += kEvlrHeader + len;
  }
}

}  // namespace

LasReader::LasReader(const std::string& path) : path_(path) {
  in_.open(path, std::ios::binary);
  if (!in_) throw FileError(path, "", "cannot open for reading");
  in_.seekg(0, std::ios::end);
  const std::uint64_t file_size = static_cast<std::uint64_t>(in_.tellg());
  if (!in_ || in_.tellg() < 0) throw FileError(path, "", "cannot determine the file size (not a regular file?)");
  file_size_ = file_size;
  in_.seekg(0);
  const HeaderBlock block = readHeaderBlock(in_, path, file_size, &header_, &point_offset_);
  const std::uint64_t count = header_.point_count;
  if (std::unique_ptr<LazVlr> laszip = readVlrs(in_, path, block.header_size, block.vlr_count, point_offset_, &header_)) {
    laz_ = std::make_unique<Laz>();
    laz_->vlr = *laszip;
  }
  if (block.compressed && !laz_) throw FileError(path, byteAt(104), "the point format says compressed (LAZ) but there is no LASzip VLR");
  // Checked by division: count · length can overflow 64 bits in a corrupt header.
  if (!laz_ && (point_offset_ > file_size || count > (file_size - point_offset_) / header_.point_record_length)) {
    throw FileError(path, byteAt(file_size),
                    "truncated: the header announces " + std::to_string(count) + " points of " +
                        std::to_string(header_.point_record_length) + " bytes from byte " + std::to_string(point_offset_) +
                        ", but the file has " + std::to_string(file_size) + " bytes");
  }
  const std::uint64_t points_end = laz_ ? point_offset_ : point_offset_ + count * header_.point_record_length;
  // EVLRs.
  if (block.evlr_count > 0) {
    if (block.evlr_start < points_end || block.evlr_start > file_size)
      throw FileError(path, byteAt(235), "start of the first EVLR is invalid");
    readEvlrs(in_, path, block.evlr_start, block.evlr_count, file_size, &header_);
  }
  if (laz_) openLaz(block.evlr_count > 0 ? block.evlr_start : file_size);
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(point_offset_));
}

void LasReader::openLaz(std::uint64_t data_end) {
  const LazVlr& v = laz_->vlr;
  const std::uint64_t count = header_.point_count, len = header_.point_record_length;
  auto readAt = [&](std::uint64_t at, void* dst, std::size_t n) {
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    return static_cast<std::size_t>(in_.gcount()) == n;
  };
  if (data_end < point_offset_ || data_end > file_size_) data_end = file_size_;
  if (v.compressor == 1) {  // one stream from the point data to the EVLRs or the end
    if (count > kMaxChunkRecordBytes / len)
      throw FileError(
          path_, "",
          "point-wise compressed (compressor 1) file of " + std::to_string(count) + " points: one stream this large is not supported");
    if (count > 0) laz_->chunks.push_back({point_offset_, data_end - point_offset_, count});
    return;
  }
  if (file_size_ < point_offset_ + 8)
    throw FileError(path_, byteAt(point_offset_), "truncated: the chunk table offset is missing after the VLRs");
  std::int64_t table = 0;
  readAt(point_offset_, &table, 8);
  if (table == -1) {  // a streaming writer puts the offset in the last 8 bytes of the file
    if (!readAt(file_size_ - 8, &table, 8)) table = 0;
  }
  if (table < static_cast<std::int64_t>(point_offset_ + 8) || static_cast<std::uint64_t>(table) + 8 > file_size_) {
    throw FileError(path_, byteAt(point_offset_),
                    "the chunk table offset " + std::to_string(table) + " points outside the compressed data (bytes " +
                        std::to_string(point_offset_ + 8) + " to " + std::to_string(file_size_) + "): missing or corrupt chunk table");
  }
  const std::uint64_t table_at = static_cast<std::uint64_t>(table);
  std::uint32_t head[2] = {0, 0};
  readAt(table_at, head, 8);
  if (head[0] != 0) throw FileError(path_, byteAt(table_at), "chunk table version " + std::to_string(head[0]) + " (0 is defined)");
  const std::uint32_t n = head[1];
  // Every chunk stores its first record raw: the chunks' bytes bound how many there can be.
  if (n > (table_at - (point_offset_ + 8)) / len) {
    throw FileError(path_, byteAt(table_at),
                    "the chunk table announces " + std::to_string(n) + " chunks; the " + std::to_string(table_at - point_offset_ - 8) +
                        " bytes of compressed data before it hold at most " + std::to_string((table_at - point_offset_ - 8) / len));
  }
  const std::uint64_t body_end = data_end > table_at + 8 ? data_end : file_size_;
  // An entry takes at most a few bytes: read no more than n of them can need.
  const std::uint64_t body_size = std::min<std::uint64_t>(body_end - (table_at + 8), 16ull * n + 64);
  std::vector<std::uint8_t> body(static_cast<std::size_t>(body_size));
  readAt(table_at + 8, body.data(), body.size());
  laz_->chunks = decodeLazChunkTable(body.data(), body.size(), n, v.variableChunks(), path_);
  std::uint64_t at = point_offset_ + 8, total = 0;
  for (std::size_t i = 0; i < laz_->chunks.size(); ++i) {
    LazChunk& c = laz_->chunks[i];
    c.offset = at;
    if (c.bytes > table_at - at) {
      throw FileError(
          path_, "chunk " + std::to_string(i) + " (byte " + std::to_string(at) + ")",
          "the chunk table gives it " + std::to_string(c.bytes) + " bytes, past the chunk table at byte " + std::to_string(table_at));
    }
    at += c.bytes;
    if (!v.variableChunks()) c.points = std::min<std::uint64_t>(v.chunk_size, count - std::min(count, total));
    if (c.points == 0 || c.points > kMaxChunkRecordBytes / len) {
      throw FileError(
          path_, "chunk " + std::to_string(i),
          std::to_string(c.points) + " points in one chunk is not supported (1 to " + std::to_string(kMaxChunkRecordBytes / len) + ")");
    }
    total += c.points;
  }
  if (total != count) {
    throw FileError(
        path_, "chunk table",
        "its " + std::to_string(n) + " chunks hold " + std::to_string(total) + " points; the header says " + std::to_string(count));
  }
}

void LasReader::decodeNextChunks() {
  Laz& z = *laz_;
  const std::size_t len = header_.point_record_length;
  // As many chunks as there are cores, within a memory budget, each decoded on its own thread.
  std::size_t k = 0;
  std::uint64_t points = 0;
  while (z.next_chunk + k < z.chunks.size() && k < decodeThreads() &&
         (k == 0 || (points + z.chunks[z.next_chunk + k].points) * len <= 2 * kMaxChunkRecordBytes)) {
    points += z.chunks[z.next_chunk + k].points;
    ++k;
  }
  if (k == 0) throw FileError(path_, "record " + std::to_string(next_), "the chunks end before the header's point count");
  std::vector<std::vector<std::uint8_t>> compressed(k);
  std::vector<std::size_t> first(k + 1, 0);
  for (std::size_t i = 0; i < k; ++i) {
    const LazChunk& c = z.chunks[z.next_chunk + i];
    compressed[i].resize(static_cast<std::size_t>(c.bytes));
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(c.offset));
    in_.read(reinterpret_cast<char*>(compressed[i].data()), static_cast<std::streamsize>(c.bytes));
    if (static_cast<std::uint64_t>(in_.gcount()) != c.bytes)
      throw FileError(path_, "chunk " + std::to_string(z.next_chunk + i), "read failed (file shrank or I/O error)");
    first[i + 1] = first[i] + static_cast<std::size_t>(c.points);
  }
  z.decoded.resize(first[k] * len);
  std::vector<std::exception_ptr> errors(k);
  auto decode = [&](std::size_t i) {
    try {
      const std::size_t index = z.next_chunk + i;
      const LazChunk& c = z.chunks[index];
      decodeLazChunk(z.vlr, compressed[i].data(), compressed[i].size(), c.points, z.decoded.data() + first[i] * len, path_,
                     "chunk " + std::to_string(index) + " (byte " + std::to_string(c.offset) + ")");
    } catch (...) {
      errors[i] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  for (std::size_t i = 1; i < k; ++i) threads.emplace_back(decode, i);
  decode(0);
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  z.next_chunk += k;
  z.decoded_points = first[k];
  z.position = 0;
}

void LasReader::fillRecords(char* dst, std::size_t n) {
  const std::size_t len = header_.point_record_length;
  if (!laz_) {
    in_.read(dst, static_cast<std::streamsize>(n * len));
    if (static_cast<std::size_t>(in_.gcount()) != n * len) {
      throw FileError(path_, "record " + std::to_string(next_), "read failed (file shrank or I/O error)");
    }
    return;
  }
  while (n > 0) {
    if (laz_->position == laz_->decoded_points) decodeNextChunks();
    const std::size_t take = std::min(n, laz_->decoded_points - laz_->position);
    std::memcpy(dst, laz_->decoded.data() + laz_->position * len, take * len);
    dst += take * len;
    laz_->position += take;
    n -= take;
  }
}

std::size_t LasReader::readRaw(std::vector<std::uint8_t>* out, std::size_t max_points) {
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_points, pointsLeft()));
  out->resize(n * header_.point_record_length);
  if (n == 0) return 0;
  fillRecords(reinterpret_cast<char*>(out->data()), n);
  next_ += n;
  return n;
}

std::size_t LasReader::read(std::vector<LasPoint>* out, std::size_t max_points) {
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(max_points, pointsLeft()));
  out->resize(n);
  if (n == 0) return 0;
  const std::size_t len = header_.point_record_length;
  buffer_.resize(n * len);
  fillRecords(buffer_.data(), n);
  const std::uint8_t f = header_.point_format;
  const std::size_t std_len = LasHeader::standardRecordLength(f);
  for (std::size_t k = 0; k < n; ++k) {
    const char* r = buffer_.data() + k * len;
    LasPoint& p = (*out)[k];
    p.X = get<std::int32_t>(r, 0);
    p.Y = get<std::int32_t>(r, 4);
    p.Z = get<std::int32_t>(r, 8);
    p.intensity = get<std::uint16_t>(r, 12);
    const std::uint8_t b14 = get<std::uint8_t>(r, 14);
    if (f < 6) {
      p.return_number = b14 & 0x07;
      p.number_of_returns = (b14 >> 3) & 0x07;
      p.scan_direction = (b14 >> 6) & 1;
      p.edge_of_flight_line = (b14 >> 7) & 1;
      p.classification = get<std::uint8_t>(r, 15);
      p.scan_angle = get<std::int8_t>(r, 16);
      p.user_data = get<std::uint8_t>(r, 17);
      p.point_source_id = get<std::uint16_t>(r, 18);
      std::size_t off = 20;
      if (f == 1 || f == 3) {
        p.gps_time = get<double>(r, off);
        off += 8;
      }
      if (f == 2 || f == 3) {
        p.red = get<std::uint16_t>(r, off);
        p.green = get<std::uint16_t>(r, off + 2);
        p.blue = get<std::uint16_t>(r, off + 4);
      }
    } else {
      const std::uint8_t b15 = get<std::uint8_t>(r, 15);
      p.return_number = b14 & 0x0F;
      p.number_of_returns = (b14 >> 4) & 0x0F;
      p.classification_flags = b15 & 0x0F;
      p.scanner_channel = (b15 >> 4) & 0x03;
      p.scan_direction = (b15 >> 6) & 1;
      p.edge_of_flight_line = (b15 >> 7) & 1;
      p.classification = get<std::uint8_t>(r, 16);
      p.user_data = get<std::uint8_t>(r, 17);
      p.scan_angle = get<std::int16_t>(r, 18);
      p.point_source_id = get<std::uint16_t>(r, 20);
      p.gps_time = get<double>(r, 22);
      if (f >= 7) {
        p.red = get<std::uint16_t>(r, 30);
        p.green = get<std::uint16_t>(r, 32);
        p.blue = get<std::uint16_t>(r, 34);
      }
      if (f == 8) p.nir = get<std::uint16_t>(r, 36);
    }
    p.extra.assign(reinterpret_cast<const std::uint8_t*>(r) + std_len, reinterpret_cast<const std::uint8_t*>(r) + len);
  }
  next_ += n;
  return n;
}

// ------------------------------------------------------------------------------------------
namespace {
bool endsWithLaz(const std::string& path) {
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".laz";
}
}  // namespace

LasWriter::LasWriter(const std::string& path, const LasHeader& header) : LasWriter(path, header, endsWithLaz(path)) {}

LasWriter::LasWriter(const std::string& path, const LasHeader& header, bool compress) : path_(path), header_(header), compress_(compress) {
  const std::uint16_t std_len = LasHeader::standardRecordLength(header_.point_format);
  if (std_len == 0 || header_.point_format == 4 || header_.point_format == 5 || header_.point_format >= 9) {
    throw FileError(path, "", "cannot write point format " + std::to_string(header_.point_format) + " (0-3 and 6-8 are supported)");
  }
  if (header_.point_record_length < std_len) header_.point_record_length = std_len;
  if (header_.point_format >= 6 && header_.version_minor < 4) header_.version_minor = 4;
  if (!header_.evlrs.empty() && header_.version_minor < 4) throw FileError(path, "", "EVLRs need LAS 1.4");
  for (int a = 0; a < 3; ++a) {
    if (!(header_.scale[a] > 0) || !std::isfinite(header_.offset[a])) throw FileError(path, "", "invalid scale or offset");
  }
  expected_count_ = header_.point_count;
  kept_min_ = header_.min;
  kept_max_ = header_.max;
  kept_by_return_ = header_.points_by_return;
  header_.point_count = 0;
  header_.points_by_return.fill(0);
  // A LASzip VLR describes a compression: the one written (if any) is this writer's own.
  header_.vlrs.erase(std::remove_if(header_.vlrs.begin(), header_.vlrs.end(),
                                    [](const LasVlr& v) { return v.user_id == kLazVlrUserId && v.record_id == kLazVlrRecordId; }),
                     header_.vlrs.end());
  if (compress_) {
    laz_vlr_ = lazVlrFor(header_.point_format, header_.point_record_length);
    LasVlr v;
    v.user_id = kLazVlrUserId;
    v.record_id = kLazVlrRecordId;
    v.description = "by mountcal (LASzip compatible)";
    v.data = serializeLazVlr(laz_vlr_);
    header_.vlrs.push_back(std::move(v));
  }
  std::random_device rd;
  tmp_path_ = path + ".tmp-" + std::to_string(rd() % 1000000u);
  out_.open(tmp_path_, std::ios::binary | std::ios::trunc);
  if (!out_) throw FileError(path, "", "cannot create the output file (does the folder exist?)");
  // Header and VLRs are written now (with zero counts) and rewritten by close(); a LAZ file
  // then has the 8-byte offset of its chunk table.
  const std::uint16_t hsize = headerSize(header_.version_minor);
  std::uint64_t offset = hsize + header_.header_padding.size();
  for (const LasVlr& v : header_.vlrs) offset += kVlrHeader + v.data.size();
  offset += header_.vlr_padding.size();
  point_offset_ = offset;
  std::vector<char> head(static_cast<std::size_t>(offset + (compress_ ? 8 : 0)), 0);
  out_.write(head.data(), static_cast<std::streamsize>(head.size()));
  record_.resize(header_.point_record_length);
}

LasWriter::~LasWriter() {
  if (!closed_) {
    out_.close();
    std::remove(tmp_path_.c_str());
  }
}

namespace {

/// std::round to 32 bits without the library call, halves away from zero. Values outside the
/// 32-bit range (and NaN) are clamped first: callers test the fit themselves. frac ∈ (−1, 1) and
/// 2·frac is exact, so its truncation is +1 from a half up, −1 from a half down, 0 between.
inline std::int32_t roundToInt32(double v) {
  const double vc = std::min(2147483647.0, std::max(-2147483648.0, v));  // max(lo, NaN) is lo
  const auto i = static_cast<std::int32_t>(vc);
  const double frac = vc - static_cast<double>(i);
  return static_cast<std::int32_t>(i + static_cast<std::int32_t>(2.0 * frac));
}

}  // namespace

std::int32_t LasWriter::quantize(int axis, double value, std::uint64_t record) const {
  const double v = (value - header_.offset[axis]) / header_.scale[axis];
  // round(v) fits in 32 bits exactly when v lies in (−2³¹ − ½, 2³¹ − ½); NaN fails too.
  if (!(v > -2147483648.5 && v < 2147483647.5)) {
    throw FileError(path_, "record " + std::to_string(record),
                    "coordinate " + std::to_string(value) + " does not fit the header's scale and offset");
  }
  return roundToInt32(v);
}

void LasWriter::quantize(const double* xyz, std::int32_t* XYZ, std::size_t n, std::uint64_t first_record) const {
  // The single-value quantize() above, without its call and test per value: the fit of the
  // whole block is tested once at the end (a value that does not fit is clamped meanwhile, then
  // quantize() names it).
  const double o0 = header_.offset[0], o1 = header_.offset[1], o2 = header_.offset[2];
  const double s0 = header_.scale[0], s1 = header_.scale[1], s2 = header_.scale[2];
  bool all_fit = true;
  for (std::size_t k = 0; k < n; ++k) {
    const double v0 = (xyz[3 * k] - o0) / s0, v1 = (xyz[3 * k + 1] - o1) / s1, v2 = (xyz[3 * k + 2] - o2) / s2;
    all_fit &= (v0 > -2147483648.5) & (v0 < 2147483647.5) & (v1 > -2147483648.5) & (v1 < 2147483647.5) & (v2 > -2147483648.5) &
               (v2 < 2147483647.5);
    XYZ[3 * k] = roundToInt32(v0);
    XYZ[3 * k + 1] = roundToInt32(v1);
    XYZ[3 * k + 2] = roundToInt32(v2);
  }
  if (all_fit) return;
  for (std::size_t k = 0; k < 3 * n; ++k) (void)quantize(static_cast<int>(k % 3), xyz[k], first_record + k / 3);  // throws
}

void LasWriter::write(const LasPoint& p) {
  char* r = record_.data();
  std::memset(r, 0, record_.size());
  const std::uint8_t f = header_.point_format;
  put<std::int32_t>(r, 0, p.X);
  put<std::int32_t>(r, 4, p.Y);
  put<std::int32_t>(r, 8, p.Z);
  put<std::uint16_t>(r, 12, p.intensity);
  if (f < 6) {
    put<std::uint8_t>(r, 14,
                      static_cast<std::uint8_t>((p.return_number & 7) | ((p.number_of_returns & 7) << 3) | (p.scan_direction << 6) |
                                                (p.edge_of_flight_line << 7)));
    put<std::uint8_t>(r, 15, p.classification);
    put<std::int8_t>(r, 16, static_cast<std::int8_t>(std::clamp<int>(p.scan_angle, -128, 127)));
    put<std::uint8_t>(r, 17, p.user_data);
    put<std::uint16_t>(r, 18, p.point_source_id);
    std::size_t off = 20;
    if (f == 1 || f == 3) {
      put<double>(r, off, p.gps_time);
      off += 8;
    }
    if (f == 2 || f == 3) {
      put<std::uint16_t>(r, off, p.red);
      put<std::uint16_t>(r, off + 2, p.green);
      put<std::uint16_t>(r, off + 4, p.blue);
    }
  } else {
    put<std::uint8_t>(r, 14, static_cast<std::uint8_t>((p.return_number & 15) | ((p.number_of_returns & 15) << 4)));
    put<std::uint8_t>(r, 15,
                      static_cast<std::uint8_t>((p.classification_flags & 15) | ((p.scanner_channel & 3) << 4) | (p.scan_direction << 6) |
                                                (p.edge_of_flight_line << 7)));
    put<std::uint8_t>(r, 16, p.classification);
    put<std::uint8_t>(r, 17, p.user_data);
    put<std::int16_t>(r, 18, p.scan_angle);
    put<std::uint16_t>(r, 20, p.point_source_id);
    put<double>(r, 22, p.gps_time);
    if (f >= 7) {
      put<std::uint16_t>(r, 30, p.red);
      put<std::uint16_t>(r, 32, p.green);
      put<std::uint16_t>(r, 34, p.blue);
    }
    if (f == 8) put<std::uint16_t>(r, 36, p.nir);
  }
  const std::size_t std_len = LasHeader::standardRecordLength(f);
  if (!p.extra.empty()) std::memcpy(r + std_len, p.extra.data(), std::min(p.extra.size(), record_.size() - std_len));
  accountBlock(reinterpret_cast<const std::uint8_t*>(r), 1);
  emit(r);
}

void LasWriter::write(const std::vector<LasPoint>& points) {
  for (const LasPoint& p : points) write(p);
}

void LasWriter::writeRaw(const std::uint8_t* records, std::size_t n) {
  const std::size_t len = header_.point_record_length;
  accountBlock(records, n);
  if (!compress_) {
    out_.write(reinterpret_cast<const char*>(records), static_cast<std::streamsize>(n * len));
    return;
  }
  for (std::size_t i = 0; i < n; ++i) emit(reinterpret_cast<const char*>(records + i * len));
}

void LasWriter::keepHeaderStatistics() { keep_statistics_ = true; }

void LasWriter::accountBlock(const std::uint8_t* records, std::size_t n) {
  if (n == 0) return;
  const std::size_t len = header_.point_record_length;
  // The header's bounds and counts over n records, the bounds taken on the stored integers:
  // x = X·scale + offset is monotonic in X, so the block's extreme coordinates are those of its
  // extreme integers (the lower one of the two for the minimum, whatever the sign of the scale).
  std::int32_t lo[3], hi[3];
  LasRecordLayout::integers(records, lo);
  LasRecordLayout::integers(records, hi);
  const int mask = header_.point_format < 6 ? 7 : 15;
  std::uint64_t by_return[16] = {};
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t* r = records + i * len;
    std::int32_t X[3];
    LasRecordLayout::integers(r, X);
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], X[a]);
      hi[a] = std::max(hi[a], X[a]);
    }
    ++by_return[r[14] & mask];
  }
  for (int a = 0; a < 3; ++a) {
    const double x_lo = lo[a] * header_.scale[a] + header_.offset[a], x_hi = hi[a] * header_.scale[a] + header_.offset[a];
    const double mn = x_hi < x_lo ? x_hi : x_lo, mx = x_hi < x_lo ? x_lo : x_hi;
    if (!any_ || mn < header_.min[a]) header_.min[a] = mn;
    if (!any_ || mx > header_.max[a]) header_.max[a] = mx;
  }
  any_ = true;
  for (std::size_t ret = 1; ret <= 15; ++ret) header_.points_by_return[ret - 1] += by_return[ret];
  header_.point_count += n;
}

void LasWriter::emit(const char* r) {
  const std::size_t len = header_.point_record_length;
  if (!compress_) {
    out_.write(r, static_cast<std::streamsize>(len));
    return;
  }
  pending_.insert(pending_.end(), reinterpret_cast<const std::uint8_t*>(r), reinterpret_cast<const std::uint8_t*>(r) + len);
  if (pending_.size() >= static_cast<std::size_t>(decodeThreads()) * laz_vlr_.chunk_size * len) flushChunks(false);
}

void LasWriter::flushChunks(bool all) {
  const std::size_t len = header_.point_record_length;
  const std::size_t points = pending_.size() / len;
  std::vector<std::size_t> first;  // first record of each chunk to encode
  for (std::size_t p = 0; p < points && (all || points - p >= laz_vlr_.chunk_size); p += laz_vlr_.chunk_size) first.push_back(p);
  if (first.empty()) return;
  const std::size_t k = first.size();
  first.push_back(std::min(points, first.back() + laz_vlr_.chunk_size));
  std::vector<std::vector<std::uint8_t>> encoded(k);
  std::vector<std::exception_ptr> errors(k);
  auto encode = [&](std::size_t i) {
    try {
      encoded[i] = encodeLazChunk(laz_vlr_, pending_.data() + first[i] * len, first[i + 1] - first[i]);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  };
  std::vector<std::thread> threads;
  for (std::size_t i = 1; i < k; ++i) threads.emplace_back(encode, i);  // chunks are independent
  encode(0);
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  for (std::size_t i = 0; i < k; ++i) {
    chunks_.push_back({0, encoded[i].size(), first[i + 1] - first[i]});
    out_.write(reinterpret_cast<const char*>(encoded[i].data()), static_cast<std::streamsize>(encoded[i].size()));
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(first[k] * len));
}

void LasWriter::close() {
  if (closed_) return;
  const std::string tmp = closeToTemporary();
  if (std::rename(tmp.c_str(), path_.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw FileError(path_, "", "cannot rename the temporary file into place");
  }
}

std::string LasWriter::closeToTemporary() {
  if (closed_) throw std::logic_error("LasWriter::closeToTemporary: " + path_ + " is already closed");
  if (keep_statistics_) {
    if (header_.point_count != expected_count_) {
      throw FileError(
          path_, "",
          std::to_string(header_.point_count) + " points written; the header kept from the input says " + std::to_string(expected_count_));
    }
    header_.min = kept_min_;
    header_.max = kept_max_;
    header_.points_by_return = kept_by_return_;
  } else if (!any_) {
    header_.min = header_.max = {0, 0, 0};
  }
  std::uint64_t chunk_table_at = 0;
  if (compress_) {
    flushChunks(true);
    chunk_table_at = static_cast<std::uint64_t>(out_.tellp());
    const std::uint32_t table_head[2] = {0, static_cast<std::uint32_t>(chunks_.size())};
    out_.write(reinterpret_cast<const char*>(table_head), 8);
    const std::vector<std::uint8_t> body = encodeLazChunkTable(chunks_, false);
    out_.write(reinterpret_cast<const char*>(body.data()), static_cast<std::streamsize>(body.size()));
  }
  const std::uint64_t evlr_start = static_cast<std::uint64_t>(out_.tellp());
  for (const LasVlr& v : header_.evlrs) {
    char vh[kEvlrHeader] = {};
    putString(vh, 2, 16, v.user_id);
    put<std::uint16_t>(vh, 18, v.record_id);
    put<std::uint64_t>(vh, 20, v.data.size());
    putString(vh, 28, 32, v.description);
    out_.write(vh, kEvlrHeader);
    out_.write(reinterpret_cast<const char*>(v.data.data()), static_cast<std::streamsize>(v.data.size()));
  }
  const std::uint16_t hsize = headerSize(header_.version_minor);
  std::vector<char> h(hsize, 0);
  std::memcpy(h.data(), "LASF", 4);
  put<std::uint16_t>(h.data(), 4, header_.file_source_id);
  put<std::uint16_t>(h.data(), 6, header_.global_encoding);
  std::memcpy(h.data() + 8, header_.project_guid.data(), 16);
  put<std::uint8_t>(h.data(), 24, 1);
  put<std::uint8_t>(h.data(), 25, header_.version_minor);
  putString(h.data(), 26, 32, header_.system_identifier);
  putString(h.data(), 58, 32, header_.generating_software);
  put<std::uint16_t>(h.data(), 90, header_.creation_day);
  put<std::uint16_t>(h.data(), 92, header_.creation_year);
  put<std::uint16_t>(h.data(), 94, static_cast<std::uint16_t>(hsize + header_.header_padding.size()));
  put<std::uint32_t>(h.data(), 96, static_cast<std::uint32_t>(point_offset_));
  put<std::uint32_t>(h.data(), 100, static_cast<std::uint32_t>(header_.vlrs.size()));
  put<std::uint8_t>(h.data(), 104, static_cast<std::uint8_t>(header_.point_format | (compress_ ? 0x80 : 0)));
  put<std::uint16_t>(h.data(), 105, header_.point_record_length);
  // Legacy counts: zero when they cannot represent the file (LAS 1.4 rule).
  const bool legacy_ok = header_.point_format < 6 && header_.point_count <= 0xFFFFFFFFull;
  put<std::uint32_t>(h.data(), 107, legacy_ok ? static_cast<std::uint32_t>(header_.point_count) : 0u);
  for (int r = 0; r < 5; ++r)
    put<std::uint32_t>(h.data(), 111 + 4 * r, legacy_ok ? static_cast<std::uint32_t>(header_.points_by_return[r]) : 0u);
  for (int a = 0; a < 3; ++a) {
    put<double>(h.data(), 131 + 8 * a, header_.scale[a]);
    put<double>(h.data(), 155 + 8 * a, header_.offset[a]);
    put<double>(h.data(), 179 + 16 * a, header_.max[a]);
    put<double>(h.data(), 187 + 16 * a, header_.min[a]);
  }
  if (header_.version_minor >= 4) {
    put<std::uint64_t>(h.data(), 235, header_.evlrs.empty() ? 0 : evlr_start);
    put<std::uint32_t>(h.data(), 243, static_cast<std::uint32_t>(header_.evlrs.size()));
    put<std::uint64_t>(h.data(), 247, header_.point_count);
    for (int r = 0; r < 15; ++r) put<std::uint64_t>(h.data(), 255 + 8 * r, header_.points_by_return[r]);
  }
  out_.seekp(0);
  out_.write(h.data(), hsize);
  out_.write(reinterpret_cast<const char*>(header_.header_padding.data()), static_cast<std::streamsize>(header_.header_padding.size()));
  for (const LasVlr& v : header_.vlrs) {
    char vh[kVlrHeader] = {};
    putString(vh, 2, 16, v.user_id);
    put<std::uint16_t>(vh, 18, v.record_id);
    put<std::uint16_t>(vh, 20, static_cast<std::uint16_t>(v.data.size()));
    putString(vh, 22, 32, v.description);
    out_.write(vh, kVlrHeader);
    out_.write(reinterpret_cast<const char*>(v.data.data()), static_cast<std::streamsize>(v.data.size()));
  }
  out_.write(reinterpret_cast<const char*>(header_.vlr_padding.data()), static_cast<std::streamsize>(header_.vlr_padding.size()));
  if (compress_) {
    const std::int64_t at = static_cast<std::int64_t>(chunk_table_at);
    out_.write(reinterpret_cast<const char*>(&at), 8);
  }
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  out_.close();
  if (!ok) {
    std::remove(tmp_path_.c_str());
    closed_ = true;
    throw FileError(path_, "", "write failed (disk full?)");
  }
  closed_ = true;
  return tmp_path_;
}

void readLas(const std::string& path, LasHeader* header, std::vector<LasPoint>* points) {
  LasReader reader(path);
  *header = reader.header();
  points->clear();
  points->reserve(static_cast<std::size_t>(reader.header().point_count));
  std::vector<LasPoint> chunk;
  while (reader.read(&chunk) > 0) points->insert(points->end(), chunk.begin(), chunk.end());
}

void writeLas(const std::string& path, const LasHeader& header, const std::vector<LasPoint>& points) {
  LasWriter writer(path, header);
  writer.write(points);
  writer.close();
}

}  // namespace mountcal::io

// ---- Extra Bytes attributes (ASPRS LAS 1.4 R15, §2.5.4.2) ------------------------------------

namespace mountcal::io {

namespace {

/// Bytes of one element of an Extra Bytes data type 1–10 (0 for anything else).
std::size_t elementSize(int base_type) {
  static const std::size_t sizes[11] = {0, 1, 1, 2, 2, 4, 4, 8, 8, 4, 8};
  return base_type >= 1 && base_type <= 10 ? sizes[base_type] : 0;
}

std::string fixedString(const std::uint8_t* p, std::size_t n) {
  std::size_t len = 0;
  while (len < n && p[len] != 0) ++len;
  return std::string(reinterpret_cast<const char*>(p), len);
}

}  // namespace

std::vector<ExtraBytesAttribute> extraBytesAttributes(const LasHeader& header, const std::string& path) {
  const LasVlr* vlr = nullptr;
  for (const auto* list : {&header.vlrs, &header.evlrs})
    for (const LasVlr& v : *list)
      if (!vlr && v.user_id == "LASF_Spec" && v.record_id == 4) vlr = &v;
  std::vector<ExtraBytesAttribute> out;
  if (!vlr) return out;
  constexpr std::size_t kDescriptor = 192;
  if (vlr->data.size() % kDescriptor != 0) {
    throw FileError(path, "Extra Bytes VLR",
                    "its " + std::to_string(vlr->data.size()) + " bytes are not a whole number of 192-byte descriptors");
  }
  std::size_t at = 0;
  const std::size_t available = header.extraBytesPerPoint();
  for (std::size_t k = 0; k < vlr->data.size() / kDescriptor; ++k) {
    const std::uint8_t* d = vlr->data.data() + k * kDescriptor;
    ExtraBytesAttribute a;
    a.data_type = d[2];
    a.options = d[3];
    a.name = fixedString(d + 4, 32);
    a.description = fixedString(d + 160, 32);
    const std::string where = "Extra Bytes descriptor " + std::to_string(k) + " ('" + a.name + "')";
    if (a.data_type == 0) {
      a.size = a.options;  // undocumented bytes: the options field holds their count
      a.options = 0;
      if (a.size == 0) throw FileError(path, where, "data type 0 with a size of 0 bytes");
    } else if (a.data_type <= 30) {
      const int base = a.data_type <= 10 ? a.data_type : (a.data_type - 1) % 10 + 1;
      a.elements = a.data_type <= 10 ? 1 : (a.data_type <= 20 ? 2 : 3);
      a.size = elementSize(base) * static_cast<std::size_t>(a.elements);
      for (int e = 0; e < 3; ++e) {
        a.scale[static_cast<std::size_t>(e)] = a.hasScale() ? bytes::get<double>(d, 112 + 8 * e) : 1.0;
        a.offset[static_cast<std::size_t>(e)] = a.hasOffset() ? bytes::get<double>(d, 136 + 8 * e) : 0.0;
        if (!std::isfinite(a.scale[static_cast<std::size_t>(e)]) || !std::isfinite(a.offset[static_cast<std::size_t>(e)]))
          throw FileError(path, where, "scale or offset is not finite");
      }
    } else {
      throw FileError(path, where, "unknown data type " + std::to_string(a.data_type) + " (1–30 and 0 are defined)");
    }
    a.byte_offset = at;
    at += a.size;
    if (at > available) {
      throw FileError(
          path, where,
          "the attributes need " + std::to_string(at) + " extra bytes per point; the point record has " + std::to_string(available));
    }
    out.push_back(a);
  }
  return out;
}

const ExtraBytesAttribute* findExtraBytesAttribute(const std::vector<ExtraBytesAttribute>& attributes, const std::string& name) {
  for (const ExtraBytesAttribute& a : attributes)
    if (a.name == name) return &a;
  return nullptr;
}

double extraBytesValue(const LasPoint& p, const ExtraBytesAttribute& a, int element) {
  if (a.data_type == 0) throw InvalidInput("extra bytes attribute '" + a.name + "' is undocumented (data type 0): it has no value");
  if (element < 0 || element >= a.elements)
    throw InvalidInput("extra bytes attribute '" + a.name + "' has no element " + std::to_string(element));
  const int base = a.data_type <= 10 ? a.data_type : (a.data_type - 1) % 10 + 1;
  const std::size_t n = elementSize(base);
  const std::size_t at = a.byte_offset + n * static_cast<std::size_t>(element);
  if (at + n > p.extra.size())
    throw InvalidInput("the point has " + std::to_string(p.extra.size()) + " extra bytes; attribute '" + a.name + "' needs " +
                       std::to_string(at + n));
  const std::uint8_t* b = p.extra.data() + at;
  double raw = 0;
  switch (base) {
    case 1:
      raw = b[0];
      break;
    case 2:
      raw = static_cast<std::int8_t>(b[0]);
      break;
    case 3:
      raw = bytes::get<std::uint16_t>(b, 0);
      break;
    case 4:
      raw = bytes::get<std::int16_t>(b, 0);
      break;
    case 5:
      raw = bytes::get<std::uint32_t>(b, 0);
      break;
    case 6:
      raw = bytes::get<std::int32_t>(b, 0);
      break;
    case 7:
      raw = static_cast<double>(bytes::get<std::uint64_t>(b, 0));
      break;
    case 8:
      raw = static_cast<double>(bytes::get<std::int64_t>(b, 0));
      break;
    case 9:
      raw = bytes::get<float>(b, 0);
      break;
    default:
      raw = bytes::get<double>(b, 0);
      break;
  }
  const auto e = static_cast<std::size_t>(element);
  return raw * (a.hasScale() ? a.scale[e] : 1.0) + (a.hasOffset() ? a.offset[e] : 0.0);
}

}  // namespace mountcal::io
