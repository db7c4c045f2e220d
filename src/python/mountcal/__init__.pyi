"""Type stub of the mountcal package (the extension module mountcal._mountcal).

Units: lever arm and positions in metres, boresight and attitude as named ([deg] or [rad]), times
in seconds. Six-parameter arrays are in the order lever arm x, y, z, boresight roll, pitch,
heading. Arrays in are float64 (n,) or (n, 3), used without a copy when C-contiguous.
"""
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

F64 = npt.NDArray[np.float64]
ArrayLike = Union[F64, Sequence[float], Sequence[Sequence[float]]]

class Error(RuntimeError):
    """Base of every mountcal error; the message names the file and the place where there is one."""

class InvalidInput(Error, ValueError):
    """An argument or data set violates a documented precondition."""

class FileError(Error, OSError):
    """A file could not be read or written, or its content is malformed."""
    path: str
    location: str

class TimeOutOfRange(Error):
    """A time outside the trajectory (mountcal never extrapolates)."""
    time_s: float

class Mounting:
    """Lever arm [m] and boresight [deg] of a scanner on an IMU, with its nominal rotation (SPEC §2)."""
    def __init__(self, lever_arm_m: ArrayLike = ..., boresight_deg: ArrayLike = ..., nominal_rotation_deg: ArrayLike = ...) -> None: ...
    @property
    def lever_arm_m(self) -> F64: ...
    @property
    def boresight_deg(self) -> F64: ...
    @property
    def R_bs(self) -> F64:
        """Scanner-to-body rotation R_bore · R_nom (3×3)."""
    def to_dict(self) -> Dict[str, F64]: ...

class Trajectory:
    """Time-sorted IMU poses in the mapping frame; attitude (roll, pitch, heading) [rad]."""
    def __init__(self, time_s: ArrayLike, position_m: ArrayLike, attitude_rad: ArrayLike, interpolation: str = "linear") -> None: ...
    def __len__(self) -> int: ...
    @property
    def start_time(self) -> float: ...
    @property
    def end_time(self) -> float: ...
    def pose(self, time_s: float) -> Tuple[F64, F64]:
        """(p_m (3,), R_mb (3, 3)) at a time; TimeOutOfRange outside the trajectory."""

def georeference(trajectory: Trajectory, mounting: Mounting, time_s: ArrayLike, r_s: ArrayLike) -> F64:
    """x_m (n, 3) = p_m + R_mb (R_bs r_s + a_b) of laser vectors r_s (n, 3) emitted at time_s (n,)."""

def inverse_georeference(trajectory: Trajectory, mounting: Mounting, time_s: ArrayLike, x_m: ArrayLike) -> F64:
    """The laser vectors r_s (n, 3) of points x_m (n, 3)."""

def apply(trajectory: Trajectory, mounting_used: Mounting, mounting: Mounting, time_s: ArrayLike, x_m: ArrayLike,
          out: Optional[F64] = None, threads: int = 0) -> F64:
    """Points georeferenced with mounting_used, as `mounting` places them (mountcal apply on arrays); out may be x_m."""

class Options:
    """Calibration settings with the job file's keys (SPEC §4), checked with the library's messages, e.g.
    Options(method=["vtpm", "planes"], estimate={"lever_arm": [True, True, False]},
    solver={"max_iterations": 50}, planes={"regions": "auto"}, threads=2)."""
    def __init__(self, *, threads: int = 0, **settings: Any) -> None: ...
    @property
    def methods(self) -> List[str]: ...
    @property
    def estimate(self) -> List[bool]: ...
    threads: int
    def to_dict(self) -> Dict[str, Any]: ...

class Job:
    """A job file read and checked (SPEC §4)."""
    @property
    def path(self) -> str: ...
    @property
    def methods(self) -> List[str]: ...
    @property
    def options(self) -> Options: ...
    @property
    def mounting_used(self) -> Mounting: ...
    @property
    def strips(self) -> List[Dict[str, str]]: ...
    @property
    def result_path(self) -> str: ...
    @property
    def report_path(self) -> str: ...
    @property
    def notices(self) -> List[str]: ...
    def to_json(self) -> str: ...

def read_job(path: str, **overrides: Any) -> Job:
    """Reads and checks a job file; keyword arguments override its top-level keys (JSON merge patch)."""

class CalibrationData:
    """What a job names, loaded: the trajectory and each strip's raw observations."""
    @property
    def strip_ids(self) -> List[str]: ...
    def __len__(self) -> int: ...
    def strip(self, key: Union[int, str]) -> Dict[str, Any]:
        """time_s (n,), r_s (n, 3), x_m (n, 3), and laser (uint16), intensity (float32) where loaded."""
    def points(self, key: Union[int, str], mounting: Mounting) -> F64:
        """A strip's points (n, 3) georeferenced with `mounting` at their own poses (per-point or from the trajectory)."""
    @property
    def trajectory(self) -> Optional[Trajectory]: ...
    @property
    def mounting_used(self) -> Mounting: ...
    @property
    def job(self) -> Optional[Job]: ...

def load_job_data(job: Job) -> CalibrationData: ...

def read_trajectory(path: str, time_offset_s: float = 0.0, interpolation: str = "linear") -> Trajectory:
    """A local-frame trajectory CSV (SPEC §4: time,x,y,z,roll_deg,pitch_deg,heading_deg); FileError with the file and line."""

def load_job_trajectory(job: Job) -> Trajectory:
    """The job's trajectory alone (no strips), in its computation frame; InvalidInput for a job with per-point poses."""

class Summary:
    """A calibration's result."""
    @property
    def mounting(self) -> Mounting: ...
    @property
    def mounting_used(self) -> Mounting: ...
    @property
    def parameter_names(self) -> List[str]: ...
    @property
    def estimated(self) -> List[bool]: ...
    @property
    def values(self) -> F64:
        """The six parameters [m, m, m, deg, deg, deg]."""
    @property
    def sigma(self) -> F64:
        """σ [m, m, m, deg, deg, deg]; NaN where not estimated."""
    @property
    def formal_sigma(self) -> F64: ...
    @property
    def sigma_model(self) -> str: ...
    @property
    def correlation(self) -> F64: ...
    @property
    def covariance(self) -> F64:
        """6×6 [m, rad]."""
    @property
    def variance_factor(self) -> float: ...
    @property
    def degrees_of_freedom(self) -> int: ...
    @property
    def unobservable(self) -> List[str]: ...
    @property
    def usable(self) -> bool: ...
    @property
    def termination(self) -> str: ...
    @property
    def message(self) -> str: ...
    @property
    def methods(self) -> List[str]: ...
    @property
    def verdict(self) -> str:
        """'accept', 'doubtful' or 'reject'."""
    @property
    def verdict_reasons(self) -> List[str]: ...
    @property
    def laser_elevation_offsets_deg(self) -> F64: ...
    @property
    def laser_intrinsics(self) -> Dict[str, F64]:
        """Per-laser intrinsics by laser id (arrays; zero for a group not estimated; empty: none)."""
    @property
    def kinds(self) -> Dict[str, Dict[str, int]]: ...
    @property
    def residuals(self) -> Dict[str, Any]:
        """Each kind's residual section of the result file."""
    def result(self) -> Dict[str, Any]:
        """The result file's content (SPEC §4), without the evaluation."""
    def report(self) -> str:
        """The table `mountcal calibrate` prints."""

def calibrate(data: CalibrationData, options: Optional[Options] = None) -> Summary:
    """Calibrates from loaded data; options None: the job's own settings."""

def calibrate_job(path: str, **overrides: Any) -> Dict[str, Any]:
    """Calibrates a job as `mountcal calibrate` does; returns the result file's content (writes nothing)."""

def presets() -> List[str]: ...

def simulate(preset: str, seed: int = 1, *, out: str, noise: bool = True, ties: bool = True, laz: bool = False, crs: str = "") -> str:
    """Simulates a preset survey into `out` as `mountcal simulate`; returns the path of its job.json."""

def read_las_header(path: str) -> Dict[str, Any]: ...

def read_strip(path: str) -> Dict[str, npt.NDArray[Any]]:
    """Every point of a LAS or LAZ file as NumPy columns; documented extra bytes by name (float64)."""
