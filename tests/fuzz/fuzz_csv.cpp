// libFuzzer target: the CSV readers (ties/check points, trajectory, GCPs, planes, raw pulses of
// each sensor type, geodetic trajectory) must refuse any malformed input with a
// mountcal::Error naming the file and line — never crash, hang or allocate without bound.
// Byte 0 selects the reader; the rest is the file.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/io/csv.hpp"
#include "mountcal/io/sbet.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const std::string path = "/tmp/mountcal_fuzz_csv_" + std::to_string(::getpid()) + ".csv";
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  using namespace mountcal;
  try {
    switch (data[0] % 8) {
      case 0:
        (void)io::readTiesCsv(path);
        break;
      case 1: {
        const Trajectory t = io::readTrajectoryCsv(path);
        (void)t.pose(0.5 * (t.startTime() + t.endTime()));
        break;
      }
      case 2:
        (void)io::readGcpCsv(path);
        break;
      case 3:
        (void)io::readPlanesCsv(path);
        break;
      case 4:
        (void)io::readRawCsv(path, SensorType::kLine);
        break;
      case 5:
        (void)io::readRawCsv(path, SensorType::kMultiBeam);
        break;
      case 6:
        (void)io::readRawCsv(path, SensorType::kVector);
        break;
      default:
        (void)io::readGeodeticTrajectoryCsv(path);
        break;
    }
  } catch (const Error&) {
  }
  return 0;
}
