"""Georeferencing and apply on NumPy arrays, against closed forms; strips read against an independent reader."""
import struct
import threading
import time

import numpy as np
import pytest

import mountcal
from conftest import data_file


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


R_MN = np.array([[0, 1, 0], [1, 0, 0], [0, 0, -1]])  # NED -> ENU (SPEC §2, local frame)


def straight_flight(n=11, heading=0.3, roll=0.01, pitch=-0.02):
    """Constant attitude, constant velocity: linear interpolation is exact, so the pose is a closed form."""
    t = np.linspace(100.0, 110.0, n)
    p = np.stack([50.0 * (t - 100.0), 10.0 * (t - 100.0), np.full(n, 500.0)], axis=1)
    att = np.tile([roll, pitch, heading], (n, 1))
    return mountcal.Trajectory(t, p, att), (roll, pitch, heading)


def hand_georeference(t, r_s, rph, lever, bore_deg):
    """x = p(t) + R_mn R_nb (R_bore r_s + a), written out from SPEC §2 without mountcal."""
    roll, pitch, heading = rph
    R_mb = R_MN @ rz(heading) @ ry(pitch) @ rx(roll)
    w, f, k = np.radians(bore_deg)
    R_bs = rz(k) @ ry(f) @ rx(w)
    p = np.stack([50.0 * (t - 100.0), 10.0 * (t - 100.0), np.full(t.shape, 500.0)], axis=1)
    return p + (R_mb @ (R_bs @ r_s.T + np.reshape(lever, (3, 1)))).T


def test_georeference_is_spec_equation_1_by_hand():
    traj, rph = straight_flight()
    rng = np.random.default_rng(1)
    t = np.sort(rng.uniform(100.0, 110.0, 1000))
    r_s = rng.normal(0.0, 300.0, (1000, 3))
    m = mountcal.Mounting(lever_arm_m=[0.1, -0.2, 0.3], boresight_deg=[0.5, -0.3, 1.2])
    x = mountcal.georeference(traj, m, t, r_s)
    assert x.shape == (1000, 3) and x.dtype == np.float64
    assert np.abs(x - hand_georeference(t, r_s, rph, [0.1, -0.2, 0.3], [0.5, -0.3, 1.2])).max() < 1e-9
    assert np.abs(mountcal.inverse_georeference(traj, m, t, x) - r_s).max() < 1e-9
    assert np.allclose(m.R_bs, rz(np.radians(1.2)) @ ry(np.radians(-0.3)) @ rx(np.radians(0.5)), atol=1e-15)


def test_apply_moves_points_as_the_new_mounting_places_them_in_place_and_not():
    traj, rph = straight_flight()
    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(100.0, 110.0, 20000))
    r_s = rng.normal(0.0, 100.0, (20000, 3))
    used = mountcal.Mounting([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    new = mountcal.Mounting([0.2, 0.1, -0.05], [0.01, -0.02, 0.05])
    x_used = hand_georeference(t, r_s, rph, [0, 0, 0], [0, 0, 0])
    expected = hand_georeference(t, r_s, rph, [0.2, 0.1, -0.05], [0.01, -0.02, 0.05])
    for threads in (1, 2, 0):
        assert np.abs(mountcal.apply(traj, used, new, t, x_used, threads=threads) - expected).max() < 1e-9
    x = x_used.copy()
    y = mountcal.apply(traj, used, new, t, x, out=x)  # in place: the caller's buffer, no copy
    assert np.shares_memory(x, y) and np.abs(x - expected).max() < 1e-9
    # A strided float64 view is accepted (copied), a list too.
    wide = np.zeros((20000, 6))
    wide[:, ::2] = x_used
    assert np.abs(mountcal.apply(traj, used, new, t, wide[:, ::2]) - expected).max() < 1e-9
    assert np.abs(mountcal.apply(traj, used, new, list(t[:3]), x_used[:3].tolist()) - expected[:3]).max() < 1e-9


def test_wrong_arrays_are_refused_with_the_argument_named():
    traj, _ = straight_flight()
    m = mountcal.Mounting()
    t = np.linspace(101, 102, 10)
    with pytest.raises(TypeError, match=r"x_m: dtype float32, expected float64"):
        mountcal.apply(traj, m, m, t, np.zeros((10, 3), np.float32))
    with pytest.raises(TypeError, match=r"time_s: dtype int64"):
        mountcal.georeference(traj, m, np.arange(10), np.zeros((10, 3)))
    with pytest.raises(ValueError, match=r"r_s: shape \(10, 2\), expected \(n, 3\)"):
        mountcal.georeference(traj, m, t, np.zeros((10, 2)))
    with pytest.raises(ValueError, match=r"x_m: 9 rows, expected 10"):
        mountcal.apply(traj, m, m, t, np.zeros((9, 3)))
    with pytest.raises(ValueError, match=r"time_s: shape \(10, 1\)"):
        mountcal.georeference(traj, m, t.reshape(10, 1), np.zeros((10, 3)))
    with pytest.raises(TypeError, match=r"out: expected a writeable C-contiguous float64"):
        mountcal.apply(traj, m, m, t, np.zeros((10, 3)), out=np.zeros((10, 3), np.float32))
    with pytest.raises(ValueError, match=r"attitude_rad: shape"):
        mountcal.Trajectory(t, np.zeros((10, 3)), np.zeros((10, 2)))
    with pytest.raises(mountcal.InvalidInput, match="strictly increasing"):
        mountcal.Trajectory(t[::-1].copy(), np.zeros((10, 3)), np.zeros((10, 3)))
    with pytest.raises(mountcal.TimeOutOfRange) as e:
        mountcal.georeference(traj, m, np.array([99.0]), np.zeros((1, 3)))
    assert e.value.time_s == 99.0 and "does not extrapolate" in str(e.value)


def test_a_mounting_takes_integers_and_names_a_wrong_vector():
    # A sensor on its side is written [180, -90, 0] in a job; the same list is a mounting here.
    ints = mountcal.Mounting([0, 0, 0], [1, 0, 0], nominal_rotation_deg=[180, -90, 0])
    floats = mountcal.Mounting([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], nominal_rotation_deg=[180.0, -90.0, 0.0])
    r = np.array([[0.0, 0.0, 10.0]])
    traj, _ = straight_flight()
    t = np.array([101.0])
    assert np.array_equal(mountcal.georeference(traj, ints, t, r), mountcal.georeference(traj, floats, t, r))
    with pytest.raises(ValueError, match=r"lever_arm_m: 2 values, expected three"):
        mountcal.Mounting([0.1, 0.2], [0.0, 0.0, 0.0])
    with pytest.raises(TypeError, match=r"boresight_deg: expected three numbers"):
        mountcal.Mounting([0.0, 0.0, 0.0], ["a", "b", "c"])


def las_points_by_hand(path):
    """X, Y, Z, GPS time and the extra bytes of a LAS 1.2 format-3 file, read with struct/NumPy only."""
    raw = open(path, "rb").read()
    assert raw[:4] == b"LASF"
    offset_to_points, = struct.unpack_from("<I", raw, 96)
    fmt, rec_len = struct.unpack_from("<BH", raw, 104)
    count, = struct.unpack_from("<I", raw, 107)
    scale = struct.unpack_from("<3d", raw, 131)
    offset = struct.unpack_from("<3d", raw, 155)
    assert fmt == 3
    dt = np.dtype([("X", "<i4"), ("Y", "<i4"), ("Z", "<i4"), ("intensity", "<u2"), ("bits", "u1"), ("cls", "u1"),
                   ("angle", "i1"), ("user", "u1"), ("src", "<u2"), ("t", "<f8"), ("rgb", "<u2", 3),
                   ("extra", "u1", rec_len - 34)])
    pts = np.frombuffer(raw, dt, count, offset_to_points)
    xyz = np.stack([pts["X"] * scale[0] + offset[0], pts["Y"] * scale[1] + offset[1], pts["Z"] * scale[2] + offset[2]], 1)
    return xyz, pts


def test_a_strip_read_equals_an_independent_reading_of_the_file():
    path = data_file("gravity/Truck.las")
    s = mountcal.read_strip(str(path))
    xyz, pts = las_points_by_hand(path)
    assert np.array_equal(np.stack([s["x"], s["y"], s["z"]], 1), xyz)
    assert np.array_equal(s["gps_time"], pts["t"]) and np.array_equal(s["user_data"], pts["user"])
    assert np.array_equal(s["intensity"], pts["intensity"]) and np.array_equal(s["extra_bytes"], pts["extra"])
    # The documented extra bytes by name: SensorX is a double at byte 4 of the extra bytes (frameNo an int32 before it).
    sensor_x = np.frombuffer(pts["extra"][:, 4:12].tobytes(), "<f8")
    assert np.array_equal(s["SensorX"], sensor_x)
    h = mountcal.read_las_header(str(path))
    assert h["point_count"] == len(xyz) and h["point_format"] == 3 and "SensorYawRads" in h["extra_bytes"]


@pytest.mark.parametrize("laz, las", [("laz/Truck.adc.laz", "gravity/Truck.las"), ("laz/extrabytes.laz", "laz/extrabytes.las"),
                                      ("laz/1815.laz", "laz/1815.las"), ("laz/point-time.las.laz", "laz/point-time.las"),
                                      ("laz/1_4_w_evlr.laz", "laz/1_4_w_evlr.las"), ("laz/simple.laz", "laz/simple.las")])
def test_laz_reads_equal_to_its_las_twin(laz, las):
    a = mountcal.read_strip(str(data_file(laz)))
    b = mountcal.read_strip(str(data_file(las)))
    assert a.keys() == b.keys() and len(a["x"]) > 0
    for k in a:
        assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f"), k
    assert mountcal.read_las_header(str(data_file(laz)))["compressed"]


def test_long_calls_release_the_gil(examples):
    """While calibrate_job runs on another thread, this one keeps running: its longest pause stays far below the call."""
    data_file("gravity/Truck.las")
    done = []
    worker = threading.Thread(target=lambda: done.append(mountcal.calibrate_job(str(examples / "gravity" / "truck.json"))))
    t0 = time.perf_counter()
    worker.start()
    last, longest = time.perf_counter(), 0.0
    while worker.is_alive():
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
        sum(range(100))
    worker.join()
    call = time.perf_counter() - t0
    assert done and call > 0.2
    assert longest < 0.25 * call, f"this thread stood still for {longest:.3f} s of a {call:.3f} s call"


def test_the_stub_states_every_public_name_and_member():
    """__init__.pyi (what editors complete) against the module itself: no name missing, none invented."""
    import ast
    import pathlib

    stub = ast.parse((pathlib.Path(mountcal.__file__).parent / "__init__.pyi").read_text())
    top = {n.name for n in stub.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    top |= {t.target.id for t in stub.body if isinstance(t, ast.AnnAssign) and t.target.id == "__version__"}
    assert top == set(mountcal.__all__)
    for cls in (n for n in stub.body if isinstance(n, ast.ClassDef)):
        members = {n.name for n in cls.body if isinstance(n, ast.FunctionDef)}
        members |= {n.target.id for n in cls.body if isinstance(n, ast.AnnAssign)}
        real = getattr(mountcal, cls.name)
        for name in members - {"__init__"}:
            assert hasattr(real, name) or issubclass(real, BaseException), f"{cls.name}.{name} is in the stub, not in the module"
        if not issubclass(real, BaseException):
            public = {k for k in dir(real) if not k.startswith("_")}
            assert public <= members, f"{cls.name}: {sorted(public - members)} are not in the stub"


def test_a_trajectory_file_is_read_with_its_poses_and_a_bad_line_named(tmp_path):
    """read_trajectory: SPEC §4's local trajectory CSV; the pose halfway between two samples by hand
    (linear position; heading 0° → 90°, so 45° at the middle)."""
    path = tmp_path / "trajectory.csv"
    path.write_text("time,x,y,z,roll_deg,pitch_deg,heading_deg\n10.0,0,0,100,0,0,0\n12.0,20,-4,102,0,0,90\n")
    tr = mountcal.read_trajectory(str(path))
    assert len(tr) == 2 and tr.start_time == 10.0 and tr.end_time == 12.0
    p, R = tr.pose(11.0)
    np.testing.assert_allclose(p, [10.0, -2.0, 101.0], atol=1e-12)
    # SPEC §2: R_mb = R_mn R_nb, n = north-east-down, heading clockwise from north, the mapping
    # frame east-north-up. At heading 45°: body x (forward) to the north-east, body y (right) to
    # the south-east, body z (down) down.
    s = np.sqrt(0.5)
    np.testing.assert_allclose(R, [[s, s, 0], [s, -s, 0], [0, 0, -1]], atol=1e-12)
    shifted = mountcal.read_trajectory(str(path), time_offset_s=5.0, interpolation="cubic")
    assert shifted.start_time == 15.0
    path.write_text("time,x,y,z,roll_deg,pitch_deg,heading_deg\n10.0,0,0,100,0,0,0\n9.0,1,1,1,0,0,0\n")
    with pytest.raises(mountcal.FileError) as e:
        mountcal.read_trajectory(str(path))
    assert e.value.path == str(path) and e.value.location
    with pytest.raises(ValueError, match="interpolation"):
        mountcal.read_trajectory(str(path), interpolation="spline")
