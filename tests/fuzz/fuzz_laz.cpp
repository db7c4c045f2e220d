// libFuzzer target: the LAZ chunk and chunk-table decoders must refuse any malformed input with
// a FileError — never crash, hang, read outside the chunk or allocate without bound.
// Input: byte 0 selects the point format (bits 0-2: 0, 1, 2, 3, 6, 7, 8, 3) and item version 1
// (bit 3, formats 0-3); byte 1 the extra bytes (0-4); bytes 2-3 the point count (1-4096; for
// layered chunks the count stored in the chunk when it is at most 50,000); the rest is a chunk.
#include <cstdint>
#include <cstring>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/io/laz.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 4) return 0;
  static const std::uint8_t kFormats[8] = {0, 1, 2, 3, 6, 7, 8, 3};
  const std::uint8_t format = kFormats[data[0] & 7];
  const int extra = data[1] % 5;
  std::uint16_t count16;
  std::memcpy(&count16, data + 2, 2);
  std::uint64_t points = 1 + count16 % 4096;
  const std::uint8_t* chunk = data + 4;
  const std::size_t chunk_size = size - 4;
  static const std::uint16_t kStandard[9] = {20, 28, 26, 34, 0, 0, 30, 36, 38};
  const std::uint16_t record_length = static_cast<std::uint16_t>(kStandard[format] + extra);
  mountcal::io::LazVlr vlr = mountcal::io::lazVlrFor(format, record_length);
  if ((data[0] & 8) && format < 6)
    for (auto& item : vlr.items) item.version = 1;
  if (format >= 6 && chunk_size >= record_length + 4u) {
    std::uint32_t stored;
    std::memcpy(&stored, chunk + record_length, 4);
    if (stored >= 1 && stored <= 50000) points = stored;
  }
  std::vector<std::uint8_t> records(points * record_length);
  try {
    mountcal::io::decodeLazChunk(vlr, chunk, chunk_size, points, records.data(), "fuzz.laz", "chunk 0");
  } catch (const mountcal::Error&) {
  }
  try {
    (void)mountcal::io::decodeLazChunkTable(chunk, chunk_size, count16 % 1024, data[1] & 8, "fuzz.laz");
  } catch (const mountcal::Error&) {
  }
  return 0;
}
