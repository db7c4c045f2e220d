#pragma once
// Internal (not installed): the one byte reader and writer of the file formats. LAS, LAZ and the
// LAS extra bytes are little-endian; so is every host mountcal builds on (checked here once).

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "mountcal's file formats assume a little-endian host"
#endif

namespace mountcal::io::bytes {

/// The T stored at byte `offset` of `base` (unaligned).
template <typename T>
T get(const void* base, std::size_t offset) {
  T v;
  std::memcpy(&v, static_cast<const unsigned char*>(base) + offset, sizeof(T));
  return v;
}

/// Stores v at byte `offset` of `base` (unaligned).
template <typename T>
void put(void* base, std::size_t offset, T v) {
  std::memcpy(static_cast<unsigned char*>(base) + offset, &v, sizeof(T));
}

/// Appends v's bytes to `out`.
template <typename T>
void put(std::vector<std::uint8_t>& out, T v) {
  const std::size_t at = out.size();
  out.resize(at + sizeof(T));
  std::memcpy(out.data() + at, &v, sizeof(T));
}

}  // namespace mountcal::io::bytes
