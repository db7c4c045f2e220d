#pragma once
/// \file job/schema.hpp
/// The job file of SPEC §4 (`mountcal calibrate JOB.json`) as a typed structure: read with
/// every field checked, and written back (the simulator writes its job.json through this).
/// Paths in a job file are relative to the job file; in a Job they are resolved.

#include <map>
#include <string>
#include <vector>

#include "mountcal/io/pose_fields.hpp"
#include "mountcal/mounting_calibrator.hpp"
#include "mountcal/core/sensor_model.hpp"

namespace mountcal {

/// Which records of a file a strip takes (`"split"`, SPEC §4 "Per-point poses"): one file
/// may hold several passes, told apart by a field such as `frameNo`.
struct StripSplit {
  std::string field;                 ///< empty: every record of the file
  double min = -1e308, max = 1e308;  ///< `"range": [min, max]`, inclusive
  /// `"part": k, "gap": g`: the k-th (1-based) run of records in file order, a new run starting
  /// where the field jumps by more than g between consecutive records; 0: no part selection.
  int part = 0;
  double gap = 0.0;
  bool active() const { return !field.empty(); }
};

/// One strip entry of a job.
struct JobStrip {
  std::string id;
  std::string path;            ///< absolute (resolved against the job file)
  std::string format = "las";  ///< "las" or "raw_csv"
  StripSplit split;            ///< LAS only
};

/// How the job's frame is given.
enum class JobFrameType { kLocal, kCrs };
/// How the job's trajectory is given.
enum class TrajectoryFormat { kCsv, kSbet };

/// A parsed job file (SPEC §4).
struct Job {
  std::string path;  ///< the job file itself
  JobFrameType frame_type = JobFrameType::kLocal;
  std::string crs;              ///< for JobFrameType::kCrs
  std::string trajectory_path;  ///< empty when the job takes per-point poses
  /// `"poses"`: each point's sensor pose from LAS extra bytes instead of a trajectory (a
  /// local-frame job: the strips' coordinates, e.g. UTM, are the computation frame).
  bool per_point_poses = false;
  io::PoseFields pose_fields;
  TrajectoryFormat trajectory_format = TrajectoryFormat::kCsv;
  double time_offset_s = 0.0;
  /// `"stochastic": {"trajectory": {"smrmsg": …}}`: the trajectory's accuracy along its time (an
  /// SBET's smrmsg file), read by loadJob into CalibrationData::trajectory_accuracy; empty: none.
  std::string trajectory_accuracy_path;
  SensorModel sensor;
  std::string sensor_model;  ///< "VLP-16", "HDL-32E", "custom" (a lasers table) or empty
  /// Multi-beam: the LAS field holding each point's laser id (`sensor.laser_field`, e.g.
  /// "user_data" in the Gravity files); empty: not read.
  std::string laser_field;  ///< read for LAS strips, with a trajectory or per-point poses
  /// Multi-beam with laser ids: loading refuses the job when a laser's elevation, recovered from
  /// the points (and poses), lies further than this from the sensor's table (checkLaserTable) —
  /// a wrong nominal rotation, attitude unit or laser field. 0: not checked
  /// (`sensor.laser_table_tolerance_deg`) [deg].
  double laser_table_tolerance_deg = 5.0;
  Vec3 nominal_rotation_deg = Vec3::Zero();
  MountingParameters mounting_used;
  std::vector<JobStrip> strips;
  std::string ties_path, gcps_path, check_points_path, check_planes_path;
  /// Method "planes": the regions CSV, or automatic patches (`"planes": "auto"`).
  std::string planes_path;
  bool planes_auto = false;
  /// Method "features": the target regions CSV (`"targets"`).
  std::string targets_path;
  /// The methods of `"method"` (a name or an array). Absent: "vtpm" when the job names a ties
  /// file, else "correspondences" (a job with no user input calibrates automatically).
  /// Options::methods holds the same list.
  MountingCalibrator::Options options;
  std::string result_path, report_path;  ///< empty when not requested
  /// The input value each method was given (e.g. "planes" → "auto" or the CSV as written).
  std::map<std::string, std::string> method_inputs;
  /// Notices for the user (deprecated keys that were still read), one sentence each.
  std::vector<std::string> notices;
};

/// Parses and validates a job file. Throws FileError naming the file and the field for an
/// unreadable file, invalid JSON, an unknown or missing field, a value of the wrong type or out
/// of range, or a method without its input (`"vtpm"` without `"ties"`, `"planes"` without
/// `"planes"`, `"features"` without `"targets"`).
/// `overrides_json` (optional): a JSON object of job keys merged into the file's before it is read
/// (RFC 7386 merge patch: objects merge key by key, other values replace, null removes), e.g.
/// `{"solver": {"max_iterations": 20}}`; read and checked like the file's own. Throws
/// InvalidInput when it is not a JSON object.
Job readJob(const std::string& path, const std::string& overrides_json = "");

/// The calibration settings alone, as a job file writes them (SPEC §4): a JSON object of
/// `"method"`, `"estimate"`, `"stochastic"`, `"solver"`, `"pulse_noise"` and each method's options
/// object (`"planes": {"regions": "auto", "sigma_m": 0.02}`). Every key and value is checked as
/// in readJob; a method's input file is not required. Throws FileError naming `name` and the
/// field, InvalidInput when the text is not a JSON object.
MountingCalibrator::Options readOptions(const std::string& json_text, const std::string& name = "options");

/// The settings of `options` as the JSON object readOptions reads (each method's options only
/// where they differ from its defaults); readOptions(optionsJson(o)) gives `o` back (a method's
/// input, such as "planes": "auto", is not among them).
std::string optionsJson(const MountingCalibrator::Options& options);

/// The job as SPEC §4 JSON, paths relative to `job.path`'s folder where they lie below it.
std::string jobJson(const Job& job);

/// Every file the job reads: the job file, the trajectory, the strips, the ties, GCP, check
/// and plane files it names.
std::vector<std::string> jobInputPaths(const Job& job);

/// Checks, before anything is computed or written, the job's outputs (`output.result`,
/// `output.report`) against every input of the job, `also_inputs` and each other (links
/// resolved), and that their folders exist. Throws FileError naming the output and what it
/// would overwrite.
void checkJobOutputs(const Job& job, const std::vector<std::string>& also_inputs = {});

}  // namespace mountcal
