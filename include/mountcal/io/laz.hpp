#pragma once
/// \file io/laz.hpp
/// LAZ (LASzip-compressed LAS): the LASzip VLR, the chunk table and the point-record codecs,
/// written for mountcal from the LAZ specification and the behaviour of the reference
/// implementations (LASzip, laz-perf); no third-party code.
///
/// What is supported (read and write unless noted):
/// - compressor 1 (point-wise, one arithmetic stream, no chunk table): read only, items v1/v2;
/// - compressor 2 (point-wise chunked): POINT10, GPSTIME11, RGB12, BYTE (extra bytes) in item
///   versions 1 (read only) and 2 — point formats 0–3;
/// - compressor 3 (layered chunked, LAS 1.4): POINT14, RGB14, RGBNIR14, BYTE14 in version 3 —
///   point formats 6–8, fixed or variable-size chunks (COPC files).
/// Not supported: wave packets (formats 4, 5, 9, 10) and the LASzip v4 items.
///
/// `LasReader` and `LasWriter` (io/las.hpp) use this header: a `.laz` file reads like a `.las`
/// file, and `LasWriter` writes LAZ for a path ending in `.laz`. The functions here are for
/// tools that handle chunks themselves (the fuzz target, benchmarks, parallel decoders).

#include <cstdint>
#include <string>
#include <vector>

namespace mountcal::io {

/// One item of the LASzip VLR's item list.
struct LazItem {
  enum Type : std::uint16_t {
    kByte = 0,
    kPoint10 = 6,
    kGpsTime11 = 7,
    kRgb12 = 8,
    kPoint14 = 10,
    kRgb14 = 11,
    kRgbNir14 = 12,
    kByte14 = 14
  };
  std::uint16_t type = 0;
  std::uint16_t size = 0;     ///< bytes of the item in a point record
  std::uint16_t version = 0;  ///< 1, 2 (point-wise items) or 3 (layered items)
};

/// The LASzip VLR (user id "laszip encoded", record id 22204), decoded.
struct LazVlr {
  static constexpr std::uint32_t kVariableChunks = 0xFFFFFFFFu;
  std::uint16_t compressor = 2;  ///< 1 point-wise, 2 point-wise chunked, 3 layered chunked
  std::uint16_t coder = 0;       ///< 0: arithmetic (the only one defined)
  std::uint8_t version_major = 3, version_minor = 4;
  std::uint16_t version_revision = 3;
  std::uint32_t options = 0;         ///< bit 0: written in LAS 1.4 compatibility mode
  std::uint32_t chunk_size = 50000;  ///< points per chunk; kVariableChunks: sizes in the table
  std::int64_t special_evlr_count = -1, special_evlr_offset = -1;
  std::vector<LazItem> items;

  bool variableChunks() const { return chunk_size == kVariableChunks; }
  /// Sum of the item sizes: the point record length the items describe.
  std::size_t recordLength() const;
};

constexpr const char* kLazVlrUserId = "laszip encoded";
constexpr std::uint16_t kLazVlrRecordId = 22204;

/// Name of an item type ("POINT10", "BYTE14", ...), or "type N" for an unknown one.
std::string lazItemName(std::uint16_t type);

/// Parses and checks the LASzip VLR's payload against the header's point format and record
/// length. Throws FileError naming `path` and the VLR for anything malformed or unsupported:
/// an unknown compressor, coder, item type or version, items that do not add up to the record
/// length, compressor 3 for a pre-1.4 point format, a zero chunk size.
LazVlr parseLazVlr(const std::vector<std::uint8_t>& data, std::uint8_t point_format, std::uint16_t record_length, const std::string& path);

/// The payload of a LASzip VLR.
std::vector<std::uint8_t> serializeLazVlr(const LazVlr& vlr);

/// The LASzip VLR mountcal writes for a point format and record length: compressor 2 with
/// version 2 items for formats 0–3, compressor 3 with version 3 items for formats 6–8; extra
/// bytes become one BYTE / BYTE14 item. Throws InvalidInput for any other format.
LazVlr lazVlrFor(std::uint8_t point_format, std::uint16_t record_length, std::uint32_t chunk_size = 50000);

/// One entry of the chunk table (or the single stream of compressor 1).
struct LazChunk {
  std::uint64_t offset = 0;  ///< first byte of the chunk in the file
  std::uint64_t bytes = 0;   ///< compressed size
  std::uint64_t points = 0;  ///< point records in the chunk
};

/// Decodes the compressed chunk table found at `table` (the bytes after the chunk table's
/// 8-byte header: version and count are passed in) into chunk sizes, and for variable chunks
/// point counts. Throws FileError naming `path` when the table is malformed.
std::vector<LazChunk> decodeLazChunkTable(const std::uint8_t* table, std::size_t size, std::uint32_t chunk_count, bool variable_chunks,
                                          const std::string& path);

/// Encodes chunk sizes (and point counts when `variable_chunks`) into a chunk table body.
std::vector<std::uint8_t> encodeLazChunkTable(const std::vector<LazChunk>& chunks, bool variable_chunks);

/// Decodes one chunk (`data`, `size` bytes) of `points` records into `records`
/// (points · vlr.recordLength() bytes). Throws FileError naming `path` and `where` (e.g.
/// "chunk 3") when the chunk is truncated or corrupt; never reads outside `data`.
void decodeLazChunk(const LazVlr& vlr, const std::uint8_t* data, std::size_t size, std::uint64_t points, std::uint8_t* records,
                    const std::string& path, const std::string& where);

/// Encodes `points` records (points · vlr.recordLength() bytes) into one chunk.
std::vector<std::uint8_t> encodeLazChunk(const LazVlr& vlr, const std::uint8_t* records, std::size_t points);

}  // namespace mountcal::io
