"""mountcal: calibration of a LiDAR system's mounting (lever arm and boresight) from overlapping strips.

The C++ library on NumPy arrays. One call calibrates a job file as the command does::

    import mountcal
    result = mountcal.calibrate_job("job.json")          # the result file's content, a dict
    print(result["mounting"], result["verdict"]["kind"])

or step by step::

    job = mountcal.read_job("job.json", solver={"max_iterations": 50})
    data = mountcal.load_job_data(job)
    summary = mountcal.calibrate(data, mountcal.Options(method="correspondences", threads=2))
    summary.values, summary.sigma, summary.correlation     # NumPy arrays [m, deg]

Arrays are float64 (n,) or (n, 3), used in place when C-contiguous; library errors raise
mountcal.Error (InvalidInput is also a ValueError, FileError also an OSError, with .path and
.location). Long calls release the GIL. See the stub (__init__.pyi) for every signature.
"""
from ._mountcal import (  # noqa: F401
    CalibrationData,
    Error,
    FileError,
    InvalidInput,
    Job,
    Mounting,
    Options,
    Summary,
    TimeOutOfRange,
    Trajectory,
    __version__,
    apply,
    calibrate,
    calibrate_job,
    georeference,
    inverse_georeference,
    load_job_data,
    load_job_trajectory,
    presets,
    read_job,
    read_las_header,
    read_strip,
    read_trajectory,
    simulate,
)

__all__ = [
    "CalibrationData", "Error", "FileError", "InvalidInput", "Job", "Mounting", "Options", "Summary",
    "TimeOutOfRange", "Trajectory", "__version__", "apply", "calibrate", "calibrate_job", "georeference",
    "inverse_georeference", "load_job_data", "load_job_trajectory", "presets", "read_job", "read_las_header", "read_strip", "read_trajectory", "simulate",
]
