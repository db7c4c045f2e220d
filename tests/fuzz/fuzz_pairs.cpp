// libFuzzer target: the correspondence pair file reader (mountcal match --out) must refuse any
// malformed input with a mountcal::Error — never crash, read out of bounds or allocate beyond
// what the bytes can hold.
#include <cstdint>

#include "mountcal/core/error.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    mountcal::CorrespondenceOptions o;
    std::array<double, 6> m{};
    const mountcal::PairCandidates p = mountcal::parsePairCandidates("fuzz.mcpair", data, size, &o, &m);
    (void)p.samples();
  } catch (const mountcal::Error&) {
  }
  return 0;
}
