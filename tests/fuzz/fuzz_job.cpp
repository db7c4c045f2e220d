// libFuzzer target: the job-file parser (JSON, SPEC §4: schema, types, ranges, paths, CRS) must
// refuse any malformed input with a mountcal::Error naming the file and the place — never
// crash, hang or allocate without bound. The input is the file; a parsed job is written back
// out (jobJson) and its input paths listed, as the command does. The same bytes are read as a
// swath QC file (qc.json, mountcal qc-summary's input), merged and written out again.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "mountcal/core/error.hpp"
#include "mountcal/job/schema.hpp"
#include "mountcal/report/swath_qc.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = "/tmp/mountcal_fuzz_job_" + std::to_string(::getpid()) + ".json";
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  using namespace mountcal;
  try {
    const Job job = readJob(path);
    (void)jobJson(job);
    (void)jobInputPaths(job);
  } catch (const Error&) {
  }
  try {
    const SwathQcResult qc = mergeSwathQc({swathQcFromJson(std::string(reinterpret_cast<const char*>(data), size))});
    (void)swathQcJson(qc);
    (void)swathQcSection(qc);
  } catch (const Error&) {
  }
  return 0;
}
