// libFuzzer target: the SBET reader (and its conversion to a trajectory) and the reader of its
// accuracy file (smrmsg, and its series) must refuse any malformed input with a mountcal::Error —
// never crash or read out of bounds.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/io/sbet.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/mountcal_fuzz_sbet_" + std::to_string(::getpid()) + ".sbet";
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    const auto records = mountcal::io::readSbet(path);
    const mountcal::LocalTangentFrame frame({records.front().lat_rad, records.front().lon_rad, 0.0});
    const auto trajectory = mountcal::io::sbetToTrajectory(path, records, frame);
    (void)trajectory.pose(trajectory.startTime());
  } catch (const mountcal::Error&) {
  }
  try {
    const mountcal::TrajectoryAccuracySeries series = mountcal::io::smrmsgToAccuracy(mountcal::io::readSmrmsg(path));
    std::string why;
    if (!series.IsValid(&why)) std::abort();  // the reader's checks make every series valid
    mountcal::Vec3 p, a;
    series.at(series.time_s.front() + 0.5, &p, &a);
  } catch (const mountcal::Error&) {
  }
  return 0;
}
