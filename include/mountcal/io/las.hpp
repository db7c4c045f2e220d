#pragma once
/// \file io/las.hpp
/// ASPRS LAS 1.2–1.4 reader and writer (LAS 1.4 R15), point data record formats 0–3 and 6–8.
///
/// Coordinates are kept as the stored integers with the header's scale and offset, so a point
/// read and written back unchanged is bit-identical. VLRs, EVLRs and per-point extra bytes are
/// preserved as opaque bytes. Reading and writing stream in chunks: a strip larger than memory
/// can be processed. LAZ (LASzip-compressed) files read and write the same way (io/laz.hpp):
/// the reader decodes chunk by chunk, on every core; the writer compresses when the output path
/// ends in `.laz`.

#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "mountcal/io/laz.hpp"

namespace mountcal::io {

/// A variable-length record (VLR) or extended VLR, kept byte for byte.
struct LasVlr {
  std::string user_id;  ///< up to 16 characters
  std::uint16_t record_id = 0;
  std::string description;  ///< up to 32 characters
  std::vector<std::uint8_t> data;
};

/// The public header block, in the fields mountcal uses or must preserve.
struct LasHeader {
  std::uint8_t version_major = 1;
  std::uint8_t version_minor = 4;
  std::uint16_t file_source_id = 0;
  std::uint16_t global_encoding = 0;  ///< bit 0: 1 = adjusted standard GPS time (− 1e9)
  std::array<std::uint8_t, 16> project_guid{};
  std::string system_identifier = "mountcal";
  std::string generating_software = "mountcal";
  std::uint16_t creation_day = 1;
  std::uint16_t creation_year = 2026;
  std::uint8_t point_format = 6;
  std::uint16_t point_record_length = 30;  ///< standard size of the format + extra bytes
  std::uint64_t point_count = 0;
  std::array<std::uint64_t, 15> points_by_return{};
  std::array<double, 3> scale{0.001, 0.001, 0.001};
  std::array<double, 3> offset{0.0, 0.0, 0.0};
  std::array<double, 3> min{0, 0, 0}, max{0, 0, 0};
  std::vector<LasVlr> vlrs;
  std::vector<LasVlr> evlrs;
  std::vector<std::uint8_t> header_padding;  ///< user bytes after the header block (kept)
  std::vector<std::uint8_t> vlr_padding;     ///< bytes between the last VLR and the points (kept)

  /// True for adjusted standard GPS time (GPS seconds − 1e9), false for GPS week seconds.
  bool adjustedStandardGpsTime() const { return (global_encoding & 1u) != 0; }
  /// Size of the standard part of a point record for `point_format` [bytes].
  static std::uint16_t standardRecordLength(std::uint8_t point_format);
  bool hasGpsTime() const { return point_format == 1 || point_format >= 3; }
  bool hasRgb() const { return point_format == 2 || point_format == 3 || point_format >= 7; }
  std::uint16_t extraBytesPerPoint() const { return static_cast<std::uint16_t>(point_record_length - standardRecordLength(point_format)); }
};

/// One point record. Coordinates are the stored integers (x = X · scale + offset).
struct LasPoint {
  std::int32_t X = 0, Y = 0, Z = 0;
  std::uint16_t intensity = 0;
  std::uint8_t return_number = 1;
  std::uint8_t number_of_returns = 1;
  std::uint8_t classification_flags = 0;  ///< formats 6+: synthetic, key-point, withheld, overlap
  std::uint8_t scanner_channel = 0;       ///< formats 6+
  bool scan_direction = false;
  bool edge_of_flight_line = false;
  std::uint8_t classification = 0;  ///< formats 0–5: low 5 bits class + 3 flag bits
  std::int16_t scan_angle = 0;      ///< formats 0–5: rank [deg]; 6+: [0.006 deg]; + to the right
  std::uint8_t user_data = 0;
  std::uint16_t point_source_id = 0;
  double gps_time = 0.0;  ///< formats 1, 3, 6+ [s]
  std::uint16_t red = 0, green = 0, blue = 0, nir = 0;
  std::vector<std::uint8_t> extra;  ///< extra bytes, kept as they are
};

/// Where a stored point record (LasReader::readRaw, LasWriter::writeRaw) keeps the fields that
/// re-georeferencing reads and rewrites (LAS 1.4 R15 tables 7–16): the integers X, Y, Z in
/// bytes 0–11 of every format, the GPS time at byte 20 (formats 1, 3, 4, 5) or 22 (6–10).
struct LasRecordLayout {
  explicit LasRecordLayout(int point_format)
      : has_gps_time(point_format != 0 && point_format != 2),
        gps_time_offset(point_format >= 6 ? 22
                        : has_gps_time    ? 20
                                          : 0) {}
  bool has_gps_time;
  std::size_t gps_time_offset;  ///< 0 when !has_gps_time

  static void integers(const std::uint8_t* record, std::int32_t XYZ[3]) { std::memcpy(XYZ, record, 12); }
  static void setIntegers(std::uint8_t* record, const std::int32_t XYZ[3]) { std::memcpy(record, XYZ, 12); }
  /// The record's GPS time [s]; only when has_gps_time.
  double gpsTime(const std::uint8_t* record) const {
    double t;
    std::memcpy(&t, record + gps_time_offset, 8);
    return t;
  }
};

/// Scan angle of `p` in degrees for the header's point format.
double scanAngleDeg(const LasHeader& header, const LasPoint& p);
/// Sets the scan angle of `p` from degrees (rounded to the format's unit, clamped to range).
void setScanAngleDeg(const LasHeader& header, double deg, LasPoint* p);

/// Streams the points of a LAS or LAZ file. Throws FileError naming the file and the byte,
/// record or chunk for anything malformed: a wrong signature, an unsupported version or format,
/// a record length shorter than the format, counts that disagree with the file size, a LAZ
/// file whose LASzip VLR, chunk table or compressed data is corrupt.
class LasReader {
 public:
  explicit LasReader(const std::string& path);
  ~LasReader();
  const LasHeader& header() const { return header_; }  ///< without the LASzip VLR; format bits clean
  const std::string& path() const { return path_; }
  std::uint64_t pointsLeft() const { return header_.point_count - next_; }
  /// Reads up to `max_points` points into `out` (replacing its content); returns the number
  /// read (0 at the end).
  std::size_t read(std::vector<LasPoint>* out, std::size_t max_points = 1u << 20);
  /// Reads up to `max_points` point records as stored (point_record_length bytes each, LAZ
  /// decoded) into `out`; returns the number read (0 at the end).
  std::size_t readRaw(std::vector<std::uint8_t>* out, std::size_t max_points = 1u << 20);
  /// The LASzip VLR of a LAZ file; null for an uncompressed file.
  const LazVlr* laz() const;
  /// The chunks of a LAZ file (empty for LAS).
  const std::vector<LazChunk>& lazChunks() const;
  /// Coordinates of a point [m].
  double x(const LasPoint& p) const { return p.X * header_.scale[0] + header_.offset[0]; }
  double y(const LasPoint& p) const { return p.Y * header_.scale[1] + header_.offset[1]; }
  double z(const LasPoint& p) const { return p.Z * header_.scale[2] + header_.offset[2]; }

 private:
  struct Laz;
  void openLaz(std::uint64_t data_end);
  void fillRecords(char* dst, std::size_t n);
  void decodeNextChunks();

  std::string path_;
  std::ifstream in_;
  LasHeader header_;
  std::uint64_t file_size_ = 0;
  std::uint64_t point_offset_ = 0;
  std::uint64_t next_ = 0;
  std::vector<char> buffer_;
  std::unique_ptr<Laz> laz_;
};

/// Writes a LAS or LAZ file through a temporary name, renamed over `path` only by close(): a
/// failed run never leaves a half file over a good one. Counts, bounds and points-by-return in
/// the header are computed from the points written (unless keepHeaderStatistics()).
class LasWriter {
 public:
  /// `header.point_format` and `header.point_record_length` define the records; version 1.2
  /// and 1.3 files are written with their shorter header blocks. The file is LAZ-compressed
  /// (LASzip compressor 2 for formats 0–3, 3 for 6–8; chunks of 50,000 points) when `path`
  /// ends in ".laz" (any case); a LASzip VLR in `header.vlrs` is replaced.
  LasWriter(const std::string& path, const LasHeader& header);
  /// As above with compression chosen explicitly.
  LasWriter(const std::string& path, const LasHeader& header, bool compress);
  ~LasWriter();  ///< removes the temporary file when close() was not reached
  LasWriter(const LasWriter&) = delete;
  LasWriter& operator=(const LasWriter&) = delete;

  const LasHeader& header() const { return header_; }
  /// Stored integer of a coordinate [m]: round((value − offset) / scale), halves away from
  /// zero. Throws FileError naming the record about to be written when it does not fit in 32
  /// bits.
  std::int32_t quantize(int axis, double value) const { return quantize(axis, value, header_.point_count); }
  /// The same, naming record `record` in the error (a caller that quantises a block of records
  /// before writing them).
  std::int32_t quantize(int axis, double value, std::uint64_t record) const;
  /// quantize() of n points at once: xyz holds x, y, z of each point [m], XYZ receives the
  /// three stored integers of each, the same values as quantize() gives one by one. Throws
  /// FileError naming record first_record + k for the first point k that does not fit.
  void quantize(const double* xyz, std::int32_t* XYZ, std::size_t n, std::uint64_t first_record) const;
  void write(const LasPoint& p);
  void write(const std::vector<LasPoint>& points);
  /// Writes `n` point records as stored (point_record_length bytes each).
  void writeRaw(const std::uint8_t* records, std::size_t n);
  /// Keeps the bounds and point counts of the header given to the constructor instead of
  /// computing them (a conversion that must not change the header); close() then checks that
  /// the number of points written equals the header's count.
  void keepHeaderStatistics();
  bool compressed() const { return compress_; }
  /// Writes the EVLRs, finalises the header and renames the file into place.
  void close();
  /// As close(), but leaves the finished file under its temporary name and returns that name:
  /// the caller places it (io::placeFilesAtomically, with other files of the same run) or
  /// removes it. Throws FileError (and removes the temporary file) when the write failed.
  std::string closeToTemporary();

 private:
  void accountBlock(const std::uint8_t* records, std::size_t n);  ///< header bounds and counts of n records
  void emit(const char* record);
  void flushChunks(bool all);

  std::string path_, tmp_path_;
  std::ofstream out_;
  LasHeader header_;
  std::vector<char> record_;
  bool closed_ = false;
  bool any_ = false;
  bool compress_ = false;
  bool keep_statistics_ = false;
  std::uint64_t expected_count_ = 0;
  std::array<double, 3> kept_min_{}, kept_max_{};
  std::array<std::uint64_t, 15> kept_by_return_{};
  LazVlr laz_vlr_;
  std::uint64_t point_offset_ = 0;
  std::vector<std::uint8_t> pending_;  // records not yet compressed
  std::vector<LazChunk> chunks_;
};

/// One attribute of the Extra Bytes VLR (user "LASF_Spec", record 4; or its EVLR): a named,
/// typed field stored in every point's extra bytes (ASPRS LAS 1.4 R15, §2.5.4.2).
struct ExtraBytesAttribute {
  std::string name;  ///< e.g. "SensorX"
  std::string description;
  std::uint8_t data_type = 0;   ///< 1–10: uchar, char, ushort, short, ulong, long, ulonglong, longlong, float, double; 0: undocumented
                                ///< bytes; 11–30 (deprecated): 2 or 3 of those
  std::uint8_t options = 0;     ///< bits: 0 no_data, 1 min, 2 max, 3 scale, 4 offset valid
  std::size_t byte_offset = 0;  ///< position in the point's extra bytes [bytes]
  std::size_t size = 0;         ///< bytes of all its elements [bytes]
  int elements = 1;             ///< 1, or 2–3 for the deprecated array types
  std::array<double, 3> scale{1, 1, 1}, offset{0, 0, 0};  ///< applied when the options say so
  bool hasScale() const { return (options & 8u) != 0; }
  bool hasOffset() const { return (options & 16u) != 0; }
};

/// The attributes of the header's Extra Bytes (E)VLR, in record order; empty without one.
/// Throws FileError (naming `path` and the descriptor) when a descriptor is malformed, or when
/// the attributes do not fit in the point record's extra bytes.
std::vector<ExtraBytesAttribute> extraBytesAttributes(const LasHeader& header, const std::string& path);

/// The attribute named `name`, or null.
const ExtraBytesAttribute* findExtraBytesAttribute(const std::vector<ExtraBytesAttribute>& attributes, const std::string& name);

/// Element `element` of attribute `a` of point `p`, with the attribute's scale and offset
/// applied (value · scale + offset). Throws InvalidInput for an undocumented (type 0)
/// attribute, an element out of range, or a point without the extra bytes.
double extraBytesValue(const LasPoint& p, const ExtraBytesAttribute& a, int element = 0);

/// Reads a whole LAS file (header and all points).
void readLas(const std::string& path, LasHeader* header, std::vector<LasPoint>* points);
/// Writes a whole LAS file atomically.
void writeLas(const std::string& path, const LasHeader& header, const std::vector<LasPoint>& points);

}  // namespace mountcal::io
