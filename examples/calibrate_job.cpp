// The library from C++: read a job file, calibrate with the job's own settings, print the
// mounting with its σ in degrees, and write the result file. Usage: calibrate_job JOB.json
#include <cstdio>

#include "mountcal/mountcal.hpp"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: calibrate_job JOB.json\n");
    return 2;
  }
  try {
    const mountcal::Job job = mountcal::readJob(argv[1]);               // every field checked
    const mountcal::CalibrationData data = mountcal::loadJobData(job);  // strips → raw observations
    // job.options holds the job's methods and settings; fresh Options would drop them.
    const mountcal::MountingCalibrator::Summary summary = mountcal::calibrate(data, job.options);
    std::printf("%s\n", summary.BriefReport().c_str());
    const auto& names = mountcal::mountingParameterNames();
    for (int k = 0; k < 6; ++k) {
      const double to_unit = k < 3 ? 1.0 : 180.0 / mountcal::kPi;  // Summary::sigma is in m and rad
      std::printf("  %-18s %+.5f %s  sigma %s\n", names[k].c_str(), summary.mounting.toArray()[k] * to_unit, k < 3 ? "m  " : "deg",
                  summary.estimated[k] ? std::to_string(summary.sigma[k] * to_unit).c_str() : "(not estimated)");
    }
    if (!job.result_path.empty()) mountcal::io::writeFileAtomically(job.result_path, mountcal::resultJson(summary));
    return summary.IsSolutionUsable() ? 0 : 1;
  } catch (const mountcal::Error& e) {  // bad input: the message names the file and the place
    std::fprintf(stderr, "calibrate_job: %s\n", e.what());
    return 2;
  }
}
