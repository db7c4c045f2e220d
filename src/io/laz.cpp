// LAZ: the LASzip VLR, the chunk table and chunk-level decoding and encoding.
#include "mountcal/io/laz.hpp"

#include <cstring>
#include <limits>

#include "io/bytes.hpp"
#include "laz_coder.hpp"
#include "laz_items.hpp"
#include "mountcal/core/error.hpp"

namespace mountcal::io {

namespace {

using bytes::get;
using bytes::put;

std::uint16_t fixedItemSize(std::uint16_t type) {
  switch (type) {
    case LazItem::kPoint10:
      return 20;
    case LazItem::kGpsTime11:
      return 8;
    case LazItem::kRgb12:
      return 6;
    case LazItem::kPoint14:
      return 30;
    case LazItem::kRgb14:
      return 6;
    case LazItem::kRgbNir14:
      return 8;
    default:
      return 0;
  }
}

/// The items a point format's record is made of, in record order (extra bytes excluded).
std::vector<std::uint16_t> itemTypesOf(std::uint8_t point_format) {
  switch (point_format) {
    case 0:
      return {LazItem::kPoint10};
    case 1:
      return {LazItem::kPoint10, LazItem::kGpsTime11};
    case 2:
      return {LazItem::kPoint10, LazItem::kRgb12};
    case 3:
      return {LazItem::kPoint10, LazItem::kGpsTime11, LazItem::kRgb12};
    case 6:
      return {LazItem::kPoint14};
    case 7:
      return {LazItem::kPoint14, LazItem::kRgb14};
    case 8:
      return {LazItem::kPoint14, LazItem::kRgbNir14};
    default:
      return {};
  }
}

}  // namespace

std::size_t LazVlr::recordLength() const {
  std::size_t n = 0;
  for (const LazItem& i : items) n += i.size;
  return n;
}

std::string lazItemName(std::uint16_t type) {
  switch (type) {
    case LazItem::kByte:
      return "BYTE";
    case LazItem::kPoint10:
      return "POINT10";
    case LazItem::kGpsTime11:
      return "GPSTIME11";
    case LazItem::kRgb12:
      return "RGB12";
    case 9:
      return "WAVEPACKET13";
    case LazItem::kPoint14:
      return "POINT14";
    case LazItem::kRgb14:
      return "RGB14";
    case LazItem::kRgbNir14:
      return "RGBNIR14";
    case 13:
      return "WAVEPACKET14";
    case LazItem::kByte14:
      return "BYTE14";
    default:
      return "type " + std::to_string(type);
  }
}

LazVlr parseLazVlr(const std::vector<std::uint8_t>& data, std::uint8_t point_format, std::uint16_t record_length, const std::string& path) {
  const std::string where = "LASzip VLR";
  if (data.size() < 34) throw FileError(path, where, "too short (" + std::to_string(data.size()) + " bytes; at least 34)");
  LazVlr v;
  const std::uint8_t* d = data.data();
  v.compressor = get<std::uint16_t>(d, 0);
  v.coder = get<std::uint16_t>(d, 2);
  v.version_major = d[4];
  v.version_minor = d[5];
  v.version_revision = get<std::uint16_t>(d, 6);
  v.options = get<std::uint32_t>(d, 8);
  v.chunk_size = get<std::uint32_t>(d, 12);
  v.special_evlr_count = get<std::int64_t>(d, 16);
  v.special_evlr_offset = get<std::int64_t>(d, 24);
  const std::uint16_t n = get<std::uint16_t>(d, 32);
  if (data.size() != 34u + 6u * n)
    throw FileError(path, where,
                    "holds " + std::to_string(data.size()) + " bytes; " + std::to_string(n) + " items need " + std::to_string(34 + 6 * n));
  for (std::uint16_t i = 0; i < n; ++i) {
    LazItem it;
    it.type = get<std::uint16_t>(d, 34 + 6u * i);
    it.size = get<std::uint16_t>(d, 36 + 6u * i);
    it.version = get<std::uint16_t>(d, 38 + 6u * i);
    v.items.push_back(it);
  }
  if (v.compressor < 1 || v.compressor > 3)
    throw FileError(path, where, "unknown compressor " + std::to_string(v.compressor) + " (1-3 are defined)");
  if (v.coder != 0) throw FileError(path, where, "unknown coder " + std::to_string(v.coder) + " (0, arithmetic, is the only one defined)");
  if (v.compressor != 1 && v.chunk_size == 0) throw FileError(path, where, "chunk size 0");
  const bool layered = v.compressor == 3;
  if (layered && point_format < 6)
    throw FileError(
        path, where,
        "layered compression (compressor 3) on point format " + std::to_string(point_format) + "; it is defined for formats 6-10");
  if (!layered && point_format >= 6)
    throw FileError(path, where,
                    "point format " + std::to_string(point_format) + " needs layered compression (compressor 3), the VLR says compressor " +
                        std::to_string(v.compressor));
  // The items must be the format's, in record order, then at most one extra-bytes item.
  const std::vector<std::uint16_t> types = itemTypesOf(point_format);
  if (types.empty())
    throw FileError(path, where, "point format " + std::to_string(point_format) + " is not supported in LAZ (0-3 and 6-8 are)");
  const std::size_t expected = types.size() + (v.items.size() > types.size() ? 1 : 0);
  for (std::size_t i = 0; i < v.items.size(); ++i) {
    const LazItem& it = v.items[i];
    const std::string name = "item " + std::to_string(i) + " (" + lazItemName(it.type) + " v" + std::to_string(it.version) + ")";
    if (i >= expected) throw FileError(path, where, name + ": more items than point format " + std::to_string(point_format) + " has");
    const std::uint16_t want = i < types.size() ? types[i] : static_cast<std::uint16_t>(layered ? LazItem::kByte14 : LazItem::kByte);
    if (it.type != want)
      throw FileError(path, where, name + ": point format " + std::to_string(point_format) + " needs " + lazItemName(want) + " here");
    const std::uint16_t size = fixedItemSize(it.type);
    if ((size != 0 && it.size != size) || it.size == 0)
      throw FileError(path, where, name + ": size " + std::to_string(it.size) + " is wrong");
    if (layered ? it.version != 3 : (it.version != 1 && it.version != 2))
      throw FileError(path, where,
                      name + ": version " + std::to_string(it.version) + " is not supported (" + (layered ? "3" : "1 and 2") + " are)");
  }
  if (v.items.size() < types.size())
    throw FileError(path, where,
                    "lists " + std::to_string(v.items.size()) + " items; point format " + std::to_string(point_format) + " needs " +
                        std::to_string(types.size()));
  if (v.recordLength() != record_length)
    throw FileError(path, where,
                    "items add up to " + std::to_string(v.recordLength()) + " bytes; the header's point record length is " +
                        std::to_string(record_length));
  if (v.compressor == 1) {
    for (const LazItem& it : v.items)
      if (it.version > 2) throw FileError(path, where, "compressor 1 with item version " + std::to_string(it.version));
  }
  return v;
}

std::vector<std::uint8_t> serializeLazVlr(const LazVlr& v) {
  std::vector<std::uint8_t> out;
  put<std::uint16_t>(out, v.compressor);
  put<std::uint16_t>(out, v.coder);
  put<std::uint8_t>(out, v.version_major);
  put<std::uint8_t>(out, v.version_minor);
  put<std::uint16_t>(out, v.version_revision);
  put<std::uint32_t>(out, v.options);
  put<std::uint32_t>(out, v.chunk_size);
  put<std::int64_t>(out, v.special_evlr_count);
  put<std::int64_t>(out, v.special_evlr_offset);
  put<std::uint16_t>(out, static_cast<std::uint16_t>(v.items.size()));
  for (const LazItem& it : v.items) {
    put<std::uint16_t>(out, it.type);
    put<std::uint16_t>(out, it.size);
    put<std::uint16_t>(out, it.version);
  }
  return out;
}

LazVlr lazVlrFor(std::uint8_t point_format, std::uint16_t record_length, std::uint32_t chunk_size) {
  const std::vector<std::uint16_t> types = itemTypesOf(point_format);
  if (types.empty()) throw InvalidInput("LAZ cannot be written for point format " + std::to_string(point_format) + " (0-3 and 6-8 can)");
  LazVlr v;
  const bool layered = point_format >= 6;
  v.compressor = layered ? 3 : 2;
  v.chunk_size = chunk_size;
  std::size_t n = 0;
  for (std::uint16_t t : types) {
    v.items.push_back({t, fixedItemSize(t), static_cast<std::uint16_t>(layered ? 3 : 2)});
    n += fixedItemSize(t);
  }
  if (record_length < n)
    throw InvalidInput("point record length " + std::to_string(record_length) + " is shorter than format " + std::to_string(point_format) +
                       " needs");
  if (record_length > n)
    v.items.push_back({static_cast<std::uint16_t>(layered ? LazItem::kByte14 : LazItem::kByte),
                       static_cast<std::uint16_t>(record_length - n), static_cast<std::uint16_t>(layered ? 3 : 2)});
  return v;
}

// ---- chunk table -------------------------------------------------------------------------------

std::vector<LazChunk> decodeLazChunkTable(const std::uint8_t* table, std::size_t size, std::uint32_t chunk_count, bool variable_chunks,
                                          const std::string& path) {
  std::vector<LazChunk> chunks;
  if (chunk_count == 0) return chunks;
  // Each entry costs at least a bit: far more entries than bytes cannot be a real table.
  if (chunk_count > 64 * static_cast<std::uint64_t>(size) + 64)
    throw FileError(path, "chunk table", std::to_string(chunk_count) + " chunks announced in " + std::to_string(size) + " bytes");
  chunks.resize(chunk_count);
  try {
    laz::Decoder dec;
    dec.init(table, table + size);
    laz::IntegerCodec ic(32, 2);
    ic.init(true);
    std::int32_t last_points = 0, last_bytes = 0;
    for (std::uint32_t i = 0; i < chunk_count; ++i) {  // each entry predicted from the one before
      if (variable_chunks) last_points = ic.decompress(dec, last_points, 0);
      last_bytes = ic.decompress(dec, last_bytes, 1);
      chunks[i].points = static_cast<std::uint32_t>(last_points);
      chunks[i].bytes = static_cast<std::uint32_t>(last_bytes);
    }
    if (dec.overrun() > 0) throw laz::Corrupt{"truncated"};
  } catch (const laz::Corrupt& e) {
    throw FileError(path, "chunk table", "corrupt (" + e.what + ")");
  }
  return chunks;
}

std::vector<std::uint8_t> encodeLazChunkTable(const std::vector<LazChunk>& chunks, bool variable_chunks) {
  std::vector<std::uint8_t> out;
  if (chunks.empty()) return out;
  laz::Encoder enc;
  enc.init(&out);
  laz::IntegerCodec ic(32, 2);
  ic.init(false);
  std::int32_t last_points = 0, last_bytes = 0;
  for (const LazChunk& c : chunks) {
    if (variable_chunks) {
      ic.compress(enc, last_points, static_cast<std::int32_t>(c.points), 0);
      last_points = static_cast<std::int32_t>(c.points);
    }
    ic.compress(enc, last_bytes, static_cast<std::int32_t>(c.bytes), 1);
    last_bytes = static_cast<std::int32_t>(c.bytes);
  }
  enc.done();
  return out;
}

// ---- chunks ------------------------------------------------------------------------------------

void decodeLazChunk(const LazVlr& vlr, const std::uint8_t* data, std::size_t size, std::uint64_t points, std::uint8_t* records,
                    const std::string& path, const std::string& where) {
  if (points == 0) return;
  const std::size_t len = vlr.recordLength();
  if (size < len)
    throw FileError(path, where,
                    "truncated: " + std::to_string(size) + " bytes cannot hold the first point record (" + std::to_string(len) + ")");
  std::memcpy(records, data, len);  // the first record of a chunk is stored raw
  std::size_t pos = len;
  try {
    if (vlr.compressor == 3) {
      if (size - pos < 4) throw laz::Corrupt{"no point count after the first record"};
      const std::uint32_t count = get<std::uint32_t>(data, pos);
      pos += 4;
      if (count != points)
        throw laz::Corrupt{"the chunk holds " + std::to_string(count) + " points, the chunk table says " + std::to_string(points)};
      std::vector<std::unique_ptr<laz::LayeredItem>> items;
      std::size_t layers = 0;
      for (const LazItem& it : vlr.items) {
        items.push_back(laz::makeLayeredItem(it));
        layers += items.back()->layers();
      }
      if ((size - pos) / 4 < layers) throw laz::Corrupt{"truncated layer sizes"};
      std::vector<std::uint32_t> layer_size(layers);
      std::vector<const std::uint8_t*> layer_data(layers);
      for (std::size_t i = 0; i < layers; ++i, pos += 4) layer_size[i] = get<std::uint32_t>(data, pos);
      for (std::size_t i = 0; i < layers; ++i) {
        if (layer_size[i] > size - pos)
          throw laz::Corrupt{"layer " + std::to_string(i) + " of " + std::to_string(layer_size[i]) + " bytes runs past the chunk's end"};
        layer_data[i] = data + pos;
        pos += layer_size[i];
      }
      // The first record starts every item; the POINT14 item hands its scanner channel on.
      std::uint32_t context = 0;
      std::size_t layer = 0, offset = 0;
      for (std::size_t i = 0; i < items.size(); ++i) {
        items[i]->initDecode(records + offset, context, layer_data.data() + layer, layer_size.data() + layer);
        layer += items[i]->layers();
        offset += vlr.items[i].size;
      }
      for (std::uint64_t p = 1; p < points; ++p) {
        std::uint8_t* record = records + p * len;
        context = 0;  // as the reference: a channel is handed on only on the point that changes it
        offset = 0;
        for (std::size_t i = 0; i < items.size(); ++i) {
          items[i]->read(record + offset, context);
          offset += vlr.items[i].size;
        }
        if ((p & 63) == 0) {  // a valid layer is never read past its end: stop garbage early
          for (const auto& item : items)
            if (item->overrun()) throw laz::Corrupt{"a layer ends at point " + std::to_string(p) + " of " + std::to_string(points)};
        }
      }
      for (const auto& item : items)
        if (item->overrun()) throw laz::Corrupt{"a layer ends before its last point"};
    } else {
      std::vector<std::unique_ptr<laz::PointwiseItem>> items;
      std::size_t offset = 0;
      for (const LazItem& it : vlr.items) {
        items.push_back(laz::makePointwiseItem(it, true));
        items.back()->init(records + offset);
        offset += it.size;
      }
      laz::Decoder dec;
      dec.init(data + pos, data + size);
      for (std::uint64_t p = 1; p < points; ++p) {
        std::uint8_t* record = records + p * len;
        offset = 0;
        for (std::size_t i = 0; i < items.size(); ++i) {
          items[i]->read(dec, record + offset);
          offset += vlr.items[i].size;
        }
        if (dec.overrun() > 0)
          throw laz::Corrupt{"the compressed data ends at point " + std::to_string(p) + " of " + std::to_string(points)};
      }
    }
  } catch (const laz::Corrupt& e) {
    throw FileError(path, where, "corrupt compressed data: " + e.what);
  }
}

std::vector<std::uint8_t> encodeLazChunk(const LazVlr& vlr, const std::uint8_t* records, std::size_t points) {
  std::vector<std::uint8_t> out;
  if (points == 0) return out;
  const std::size_t len = vlr.recordLength();
  out.assign(records, records + len);
  if (vlr.compressor == 3) {
    std::vector<std::unique_ptr<laz::LayeredItem>> items;
    std::uint32_t context = 0;
    std::size_t offset = 0;
    for (const LazItem& it : vlr.items) {
      items.push_back(laz::makeLayeredItem(it));
      items.back()->initEncode(records + offset, context);
      offset += it.size;
    }
    for (std::size_t p = 1; p < points; ++p) {
      const std::uint8_t* record = records + p * len;
      context = 0;
      offset = 0;
      for (std::size_t i = 0; i < items.size(); ++i) {
        items[i]->write(record + offset, context);
        offset += vlr.items[i].size;
      }
    }
    put<std::uint32_t>(out, static_cast<std::uint32_t>(points));
    std::vector<std::vector<std::uint8_t>> layers;
    for (auto& item : items)
      for (auto& layer : item->finish()) layers.push_back(std::move(layer));
    for (const auto& layer : layers) put<std::uint32_t>(out, static_cast<std::uint32_t>(layer.size()));
    for (const auto& layer : layers) out.insert(out.end(), layer.begin(), layer.end());
  } else {
    std::vector<std::unique_ptr<laz::PointwiseItem>> items;
    std::size_t offset = 0;
    for (const LazItem& it : vlr.items) {
      items.push_back(laz::makePointwiseItem(it, false));
      items.back()->init(records + offset);
      offset += it.size;
    }
    laz::Encoder enc;
    enc.init(&out);
    for (std::size_t p = 1; p < points; ++p) {
      const std::uint8_t* record = records + p * len;
      offset = 0;
      for (std::size_t i = 0; i < items.size(); ++i) {
        items[i]->write(enc, record + offset);
        offset += vlr.items[i].size;
      }
    }
    enc.done();
  }
  return out;
}

}  // namespace mountcal::io
