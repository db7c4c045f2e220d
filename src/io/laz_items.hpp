#pragma once
// Internal: the LAZ item codecs. Point-wise items (versions 1 and 2) share one arithmetic stream
// per chunk; layered items (version 3, LAS 1.4 formats) code each field group into its own
// layer and keep one set of models per scanner channel ("context").

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "laz_coder.hpp"
#include "mountcal/io/laz.hpp"

namespace mountcal::io::laz {

/// A point-wise item codec (compressors 1 and 2).
class PointwiseItem {
 public:
  virtual ~PointwiseItem() = default;
  /// Starts a chunk from the item's raw bytes in the chunk's first record.
  virtual void init(const std::uint8_t* item) = 0;
  virtual void read(Decoder& dec, std::uint8_t* item) = 0;
  virtual void write(Encoder& enc, const std::uint8_t* item) = 0;
};

/// A layered item codec (compressor 3). `context` is the scanner channel the POINT14 item
/// hands to the items after it.
class LayeredItem {
 public:
  virtual ~LayeredItem() = default;
  virtual std::size_t layers() const = 0;
  /// Starts decoding a chunk: `layer_data[i]`/`layer_size[i]` hold this item's layers.
  virtual void initDecode(const std::uint8_t* item, std::uint32_t& context, const std::uint8_t* const* layer_data,
                          const std::uint32_t* layer_size) = 0;
  virtual void read(std::uint8_t* item, std::uint32_t& context) = 0;
  /// Checks after the chunk that no layer was read past its end.
  virtual bool overrun() const = 0;
  virtual void initEncode(const std::uint8_t* item, std::uint32_t& context) = 0;
  virtual void write(const std::uint8_t* item, std::uint32_t& context) = 0;
  /// Finishes the chunk: one byte vector per layer, empty for a layer whose values never
  /// changed (its size is written as 0 and the decoder repeats the first value).
  virtual std::vector<std::vector<std::uint8_t>> finish() = 0;
};

/// Point-wise codec for an item of the VLR (versions 1 and 2; version 1 decodes only).
std::unique_ptr<PointwiseItem> makePointwiseItem(const LazItem& item, bool decoder);
/// Layered codec for an item of the VLR (version 3).
std::unique_ptr<LayeredItem> makeLayeredItem(const LazItem& item);

}  // namespace mountcal::io::laz
