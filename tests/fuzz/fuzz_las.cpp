// libFuzzer target: the LAS reader must refuse any malformed input with a FileError — never
// crash, hang, read out of bounds or allocate without bound.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/las_crs.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/mountcal_fuzz_las_" + std::to_string(::getpid()) + ".las";
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    mountcal::io::LasReader reader(path);
    // Extra Bytes descriptors: parsed, then every attribute of every point decoded.
    const auto attributes = mountcal::io::extraBytesAttributes(reader.header(), path);
    (void)mountcal::io::lasCrs(reader.header(), path).summary();  // the CRS records: WKT, GeoTIFF keys
    std::vector<mountcal::io::LasPoint> chunk;
    while (reader.read(&chunk, 4096) > 0) {
      for (const auto& p : chunk) {
        (void)mountcal::io::scanAngleDeg(reader.header(), p);
        for (const auto& a : attributes) {
          if (a.data_type == 0) continue;
          for (int e = 0; e < a.elements; ++e) (void)mountcal::io::extraBytesValue(p, a, e);
        }
      }
    }
  } catch (const mountcal::Error&) {
  }
  return 0;
}
