// The Python extension module `mountcal._mountcal` (issue 31): the library on NumPy arrays.
// The package `mountcal` (src/python/mountcal/__init__.py) re-exports everything defined here;
// its stub (__init__.pyi) documents the signatures for editors.
//
// Conventions: arrays in are float64, C-contiguous (n,) or (n, 3), used in place (no copy);
// anything else is refused with TypeError / ValueError naming the argument. Arrays out are new
// NumPy arrays written by the library directly. Every long call releases the GIL. Library errors
// become mountcal.Error and its subclasses, carrying the library's message (file and place).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "core/huge_pages.hpp"
#include "mountcal/mountcal.hpp"

namespace py = pybind11;
using namespace mountcal;

namespace {

constexpr double kDeg = 180.0 / kPi;

// ---- JSON through Python's json module (the library's text formats) ------------------------
py::object fromJson(const std::string& text) { return py::module_::import("json").attr("loads")(text); }
std::string toJson(const py::handle& obj) {
  return py::module_::import("json").attr("dumps")(obj, py::arg("allow_nan") = false).cast<std::string>();
}

// ---- arrays --------------------------------------------------------------------------------
using F64 = py::array_t<double, py::array::c_style | py::array::forcecast>;

/// `obj` as a float64 array of shape (n,) (cols 0) or (n, cols), C-contiguous: the caller's own
/// buffer when it is one (no copy); a list or a strided float64 array is converted. Another dtype
/// is refused (TypeError), a wrong shape or length too (ValueError), naming `what`.
F64 requireF64(const py::handle& obj, const std::string& what, int cols, py::ssize_t n = -1) {
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
    if (!a.dtype().is(py::dtype::of<double>()))
      throw py::type_error(what + ": dtype " + py::str(a.dtype()).cast<std::string>() +
                           ", expected float64 (convert with .astype(numpy.float64))");
  } else {
    a = py::array::ensure(obj);
    if (!a) throw py::type_error(what + ": expected a NumPy array of float64");
    a = a.attr("astype")(py::dtype::of<double>());
  }
  const std::string shape = cols > 0 ? "(n, " + std::to_string(cols) + ")" : "(n,)";
  if (a.ndim() != (cols > 0 ? 2 : 1) || (cols > 0 && a.shape(1) != cols))
    throw py::value_error(what + ": shape " + py::str(a.attr("shape")).cast<std::string>() + ", expected " + shape);
  if (n >= 0 && a.shape(0) != n)
    throw py::value_error(what + ": " + std::to_string(a.shape(0)) + " rows, expected " + std::to_string(n) + " (one per time)");
  return F64::ensure(a);  // C-contiguous float64: the same buffer when it already is one
}

/// A new (n, 3) float64 array for a result, on transparent huge pages where the kernel has them:
/// a fresh 240 MB array (10 M points) would otherwise be faulted in 4 KiB page by page, which cost
/// more than the georeferencing itself (bench/bench_python.cpp).
F64 newPoints(py::ssize_t n) {
  F64 a({n, py::ssize_t{3}});
  detail::adviseHugePages(a.data(), static_cast<std::size_t>(a.nbytes()));
  return a;
}

F64 vec3(const Vec3& v) {
  F64 a(3);
  std::memcpy(a.mutable_data(), v.data(), 3 * sizeof(double));
  return a;
}
/// Three numbers (a list, a tuple or an array of any integer or floating dtype: [180, -90, 0] is
/// as good as [180.0, -90.0, 0.0] for a 3-vector); anything else refused naming `what`.
Vec3 toVec3(const py::handle& obj, const std::string& what) {
  py::array a = py::array::ensure(obj);
  const char kind = a ? a.dtype().kind() : '?';
  if (kind != 'f' && kind != 'i' && kind != 'u') throw py::type_error(what + ": expected three numbers");
  if (a.size() != 3) throw py::value_error(what + ": " + std::to_string(a.size()) + " values, expected three");
  const F64 v = requireF64(a.attr("astype")(py::dtype::of<double>()).attr("reshape")(1, 3), what, 3);
  return Vec3(v.at(0, 0), v.at(0, 1), v.at(0, 2));
}
template <class Matrix>
F64 mat(const Matrix& m) {
  F64 a({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  for (Eigen::Index r = 0; r < m.rows(); ++r)
    for (Eigen::Index c = 0; c < m.cols(); ++c) a.mutable_at(r, c) = m(r, c);
  return a;
}
template <class T>
py::array_t<T> fromVector(const std::vector<T>& v) {
  py::array_t<T> a(static_cast<py::ssize_t>(v.size()));
  if (!v.empty()) std::memcpy(a.mutable_data(), v.data(), v.size() * sizeof(T));
  return a;
}
F64 fromVec3s(const std::vector<Vec3>& v) {
  F64 a({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  double* d = a.mutable_data();
  for (std::size_t i = 0; i < v.size(); ++i) std::memcpy(d + 3 * i, v[i].data(), 3 * sizeof(double));
  return a;
}

// ---- objects held by the Python classes ----------------------------------------------------
/// A job's loaded data with the job it came from (calibrate(data) takes the job's settings).
struct PyData {
  std::shared_ptr<const Job> job;  // null for data built otherwise
  std::shared_ptr<const LoadedJob> loaded;
};

const StripData& stripOf(const PyData& d, const py::object& key) {
  const auto& strips = d.loaded->data.strips;
  if (py::isinstance<py::int_>(key)) {
    const long i = key.cast<long>();
    if (i < 0 || i >= static_cast<long>(strips.size()))
      throw py::index_error("strip index " + std::to_string(i) + " out of range (" + std::to_string(strips.size()) + " strips)");
    return strips[static_cast<std::size_t>(i)];
  }
  const std::string id = key.cast<std::string>();
  for (const StripData& s : strips)
    if (s.id == id) return s;
  throw py::key_error("no strip '" + id + "'");
}

py::dict stripDict(const StripData& s) {
  py::dict d;
  d["id"] = s.id;
  d["time_s"] = fromVector(s.time_s);
  d["r_s"] = fromVec3s(s.r_s);
  d["x_m"] = fromVec3s(s.x_m);
  if (!s.laser.empty()) d["laser"] = fromVector(s.laser);
  if (!s.intensity.empty()) d["intensity"] = fromVector(s.intensity);
  return d;
}

MountingCalibrator::Options optionsFromKwargs(const py::kwargs& kw) {
  py::dict settings;
  int threads = 0;
  for (const auto& item : kw) {
    const std::string key = item.first.cast<std::string>();
    if (key == "threads")
      threads = item.second.cast<int>();
    else
      settings[item.first] = item.second;
  }
  MountingCalibrator::Options o;
  try {
    o = readOptions(toJson(settings), "Options");
  } catch (const FileError& e) {        // not a file: a wrong keyword value is a ValueError
    const std::string what = e.what();  // "<path>:<location>: message" or "<path>: message"
    throw InvalidInput("Options: " + what.substr(e.path().size() + (e.location().empty() ? 2 : 1)));
  }
  if (threads < 0) throw py::value_error("Options: threads must be ≥ 0 (0: every core)");
  o.threads = threads;
  return o;
}

py::dict mountingDict(const MountingParameters& m) {
  py::dict d;
  d["lever_arm_m"] = vec3(m.a_b);
  d["boresight_deg"] = vec3(m.boresightDeg());
  return d;
}

F64 sixInUnits(const std::array<double, 6>& v) {  // [m, m, m, deg, deg, deg]
  F64 a(6);
  for (int k = 0; k < 6; ++k) a.mutable_at(k) = k < 3 ? v[static_cast<std::size_t>(k)] : v[static_cast<std::size_t>(k)] * kDeg;
  return a;
}

void bindExceptions(py::module_& m) {
  static py::exception<Error> error(m, "Error", PyExc_RuntimeError);
  // InvalidInput is also a ValueError, FileError also an OSError: `except ValueError` catches it.
  static py::object invalid = py::reinterpret_steal<py::object>(
      PyErr_NewException("mountcal.InvalidInput", py::make_tuple(error, py::handle(PyExc_ValueError)).ptr(), nullptr));
  static py::object file_error = py::reinterpret_steal<py::object>(
      PyErr_NewException("mountcal.FileError", py::make_tuple(error, py::handle(PyExc_OSError)).ptr(), nullptr));
  static py::object time_range =
      py::reinterpret_steal<py::object>(PyErr_NewException("mountcal.TimeOutOfRange", py::make_tuple(error).ptr(), nullptr));
  m.attr("InvalidInput") = invalid;
  m.attr("FileError") = file_error;
  m.attr("TimeOutOfRange") = time_range;
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const FileError& e) {
      // OSError(message) with the library's path and place as attributes.
      py::object exc = file_error(std::string(e.what()));
      exc.attr("path") = e.path();
      exc.attr("location") = e.location();
      PyErr_SetObject(file_error.ptr(), exc.ptr());
    } catch (const InvalidInput& e) {
      PyErr_SetString(invalid.ptr(), e.what());
    } catch (const TimeOutOfRange& e) {
      py::object exc = time_range(std::string(e.what()));
      exc.attr("time_s") = e.time_s();
      PyErr_SetObject(time_range.ptr(), exc.ptr());
    }
  });
}

void bindGeometry(py::module_& m) {
  py::class_<MountingParameters>(m, "Mounting",
                                 "Lever arm [m] and boresight [deg] of a scanner on an IMU, with its nominal rotation (SPEC §2).")
      .def(py::init([](const py::object& lever_arm_m, const py::object& boresight_deg, const py::object& nominal_rotation_deg) {
             return MountingParameters::fromDegrees(toVec3(lever_arm_m, "lever_arm_m"), toVec3(boresight_deg, "boresight_deg"),
                                                    toVec3(nominal_rotation_deg, "nominal_rotation_deg"));
           }),
           py::arg("lever_arm_m") = std::vector<double>{0, 0, 0}, py::arg("boresight_deg") = std::vector<double>{0, 0, 0},
           py::arg("nominal_rotation_deg") = std::vector<double>{0, 0, 0})
      .def_property_readonly("lever_arm_m", [](const MountingParameters& p) { return vec3(p.a_b); })
      .def_property_readonly("boresight_deg", [](const MountingParameters& p) { return vec3(p.boresightDeg()); })
      .def_property_readonly(
          "R_bs", [](const MountingParameters& p) { return mat(p.R_bs()); }, "Scanner-to-body rotation R_bore · R_nom (3×3).")
      .def("to_dict", &mountingDict)
      .def("__repr__", [](const MountingParameters& p) {
        const Vec3 b = p.boresightDeg();
        char s[200];
        std::snprintf(s, sizeof s, "Mounting(lever_arm_m=[%.4f, %.4f, %.4f], boresight_deg=[%.5f, %.5f, %.5f])", p.a_b.x(), p.a_b.y(),
                      p.a_b.z(), b.x(), b.y(), b.z());
        return std::string(s);
      });

  py::class_<Trajectory, std::shared_ptr<Trajectory>>(m, "Trajectory",
                                                      "Time-sorted IMU poses in the mapping frame (local frame: x east, y north, z up).")
      .def(py::init([](const py::object& time_s, const py::object& position_m, const py::object& attitude_rad, const std::string& interp) {
             const F64 t = requireF64(time_s, "time_s", 0);
             const F64 p = requireF64(position_m, "position_m", 3, t.shape(0));
             const F64 a = requireF64(attitude_rad, "attitude_rad", 3, t.shape(0));
             if (interp != "linear" && interp != "cubic") throw py::value_error("interpolation: expected 'linear' or 'cubic'");
             std::vector<TrajectorySample> samples(static_cast<std::size_t>(t.shape(0)));
             for (std::size_t i = 0; i < samples.size(); ++i) {
               const auto k = static_cast<py::ssize_t>(i);
               samples[i].time_s = t.at(k);
               samples[i].p_m = Vec3(p.at(k, 0), p.at(k, 1), p.at(k, 2));
               samples[i].roll = a.at(k, 0), samples[i].pitch = a.at(k, 1), samples[i].heading = a.at(k, 2);
             }
             return std::make_shared<Trajectory>(std::move(samples),
                                                 interp == "cubic" ? PositionInterpolation::kCubic : PositionInterpolation::kLinear);
           }),
           py::arg("time_s"), py::arg("position_m"), py::arg("attitude_rad"), py::arg("interpolation") = "linear")
      .def("__len__", &Trajectory::size)
      .def_property_readonly("start_time", &Trajectory::startTime)
      .def_property_readonly("end_time", &Trajectory::endTime)
      .def(
          "pose",
          [](const Trajectory& tr, double t) {
            const Pose p = tr.pose(t);
            return py::make_tuple(vec3(p.p_m), mat(p.R_mb));
          },
          py::arg("time_s"), "(p_m (3,), R_mb (3, 3)) at a time; TimeOutOfRange outside the trajectory.");
  m.def(
      "read_trajectory",
      [](const std::string& path, double time_offset_s, const std::string& interp) {
        if (interp != "linear" && interp != "cubic") throw py::value_error("interpolation: expected 'linear' or 'cubic'");
        const PositionInterpolation kind = interp == "cubic" ? PositionInterpolation::kCubic : PositionInterpolation::kLinear;
        py::gil_scoped_release release;
        return std::make_shared<Trajectory>(io::readTrajectoryCsv(path, time_offset_s, kind));
      },
      py::arg("path"), py::arg("time_offset_s") = 0.0, py::arg("interpolation") = "linear",
      "A local-frame trajectory CSV (SPEC §4: time,x,y,z,roll_deg,pitch_deg,heading_deg), time_offset_s added to every time; "
      "FileError with the file and line. Geodetic trajectories (SBET) need the job's frame: load_job_trajectory.");
}

/// georeference, inverse_georeference and apply on (n, 3) arrays.
void bindGeoreferencing(py::module_& m) {
  auto model = [](const std::shared_ptr<Trajectory>& tr, const MountingParameters& mo) {
    if (!tr) throw py::value_error("trajectory: None");
    return GeoreferenceModel(std::shared_ptr<const Trajectory>(tr), mo);
  };
  // x_m of r_s (forward) or r_s of x_m: the same arrays, the other direction.
  auto map = [model](bool forward, const std::shared_ptr<Trajectory>& tr, const MountingParameters& mo, const py::object& time_s,
                     const py::object& in, const char* in_name) {
    const F64 t = requireF64(time_s, "time_s", 0);
    const F64 a = requireF64(in, in_name, 3, t.shape(0));
    F64 b = newPoints(t.shape(0));
    const GeoreferenceModel g = model(tr, mo);
    const double *pt = t.data(), *pa = a.data();
    double* pb = b.mutable_data();
    const auto n = static_cast<std::size_t>(t.shape(0));
    {
      py::gil_scoped_release release;
      forward ? g.forward(pt, pa, pb, n) : g.inverse(pt, pa, pb, n);
    }
    return b;
  };
  m.def(
      "georeference",
      [map](const std::shared_ptr<Trajectory>& tr, const MountingParameters& mo, const py::object& time_s, const py::object& r_s) {
        return map(true, tr, mo, time_s, r_s, "r_s");
      },
      py::arg("trajectory"), py::arg("mounting"), py::arg("time_s"), py::arg("r_s"),
      "x_m = p_m + R_mb (R_bs r_s + a_b) (SPEC §2 eq. 1) of laser vectors r_s (n, 3) emitted at time_s (n,).");
  m.def(
      "inverse_georeference",
      [map](const std::shared_ptr<Trajectory>& tr, const MountingParameters& mo, const py::object& time_s, const py::object& x_m) {
        return map(false, tr, mo, time_s, x_m, "x_m");
      },
      py::arg("trajectory"), py::arg("mounting"), py::arg("time_s"), py::arg("x_m"), "The laser vectors r_s (n, 3) of points x_m (n, 3).");
  m.def(
      "apply",
      [model](const std::shared_ptr<Trajectory>& tr, const MountingParameters& used, const MountingParameters& mounting,
              const py::object& time_s, const py::object& x_m, const py::object& out, int threads) {
        const F64 t = requireF64(time_s, "time_s", 0);
        const F64 x = requireF64(x_m, "x_m", 3, t.shape(0));
        F64 y;
        if (out.is_none()) {
          y = newPoints(t.shape(0));
        } else {
          if (!py::isinstance<F64>(out) || !py::array(out).dtype().is(py::dtype::of<double>()) ||
              !(py::array(out).flags() & py::array::c_style) || !py::array(out).writeable())
            throw py::type_error("out: expected a writeable C-contiguous float64 array");
          y = py::reinterpret_borrow<F64>(out);
          if (y.ndim() != 2 || y.shape(0) != t.shape(0) || y.shape(1) != 3) throw py::value_error("out: expected shape (n, 3) as x_m");
        }
        const GeoreferenceModel from = model(tr, used), to = model(tr, mounting);
        const double *pt = t.data(), *px = x.data();
        double* py_ = y.mutable_data();
        const auto n = static_cast<std::size_t>(t.shape(0));
        {
          py::gil_scoped_release release;
          reGeoreference(from, to, pt, px, py_, n, threads);
        }
        return y;
      },
      py::arg("trajectory"), py::arg("mounting_used"), py::arg("mounting"), py::arg("time_s"), py::arg("x_m"), py::arg("out") = py::none(),
      py::arg("threads") = 0,
      "Points x_m (n, 3) georeferenced with mounting_used, as `mounting` places them (what `mountcal apply` does to a strip). "
      "out: write there (may be x_m itself); threads: 0 = every core.");
}

void bindJobs(py::module_& m) {
  py::class_<MountingCalibrator::Options>(m, "Options",
                                          "The calibration settings, keyword-constructible with the job file's keys (SPEC §4): "
                                          "method, estimate, stochastic, solver, pulse_noise, each method's options object; "
                                          "and threads. Checked with the library's messages.")
      .def(py::init(&optionsFromKwargs))
      .def_property_readonly("methods", [](const MountingCalibrator::Options& o) { return o.methods; })
      .def_property(
          "threads", [](const MountingCalibrator::Options& o) { return o.threads; },
          [](MountingCalibrator::Options& o, int t) {
            if (t < 0) throw py::value_error("threads must be ≥ 0 (0: every core)");
            o.threads = t;
          })
      .def_property_readonly("estimate",
                             [](const MountingCalibrator::Options& o) { return std::vector<bool>(o.estimate.begin(), o.estimate.end()); })
      .def("to_dict", [](const MountingCalibrator::Options& o) { return fromJson(optionsJson(o)); })
      .def("__repr__", [](const MountingCalibrator::Options& o) { return "Options(" + toJson(fromJson(optionsJson(o))) + ")"; });

  py::class_<Job, std::shared_ptr<Job>>(m, "Job", "A job file read and checked (SPEC §4); paths resolved against its folder.")
      .def_property_readonly("path", [](const Job& j) { return j.path; })
      .def_property_readonly("methods", [](const Job& j) { return j.options.methods; })
      .def_property_readonly("options", [](const Job& j) { return j.options; })
      .def_property_readonly("mounting_used", [](const Job& j) { return j.mounting_used; })
      .def_property_readonly("strips",
                             [](const Job& j) {
                               py::list l;
                               for (const JobStrip& s : j.strips)
                                 l.append(py::dict(py::arg("id") = s.id, py::arg("path") = s.path, py::arg("format") = s.format));
                               return l;
                             })
      .def_property_readonly("result_path", [](const Job& j) { return j.result_path; })
      .def_property_readonly("report_path", [](const Job& j) { return j.report_path; })
      .def_property_readonly("notices", [](const Job& j) { return j.notices; })
      .def("to_json", &jobJson, "The job as SPEC §4 JSON text.");

  m.def(
      "read_job",
      [](const std::string& path, const py::kwargs& overrides) {
        return std::make_shared<Job>(readJob(path, overrides.empty() ? std::string() : toJson(overrides)));
      },
      py::arg("path"), "Reads and checks a job file; keyword arguments override its top-level keys (merge patch).");

  py::class_<PyData>(m, "CalibrationData", "What a job names, loaded: the trajectory and each strip's raw observations.")
      .def_property_readonly("strip_ids",
                             [](const PyData& d) {
                               std::vector<std::string> ids;
                               for (const StripData& s : d.loaded->data.strips) ids.push_back(s.id);
                               return ids;
                             })
      .def("__len__", [](const PyData& d) { return d.loaded->data.strips.size(); })
      .def(
          "strip", [](const PyData& d, const py::object& key) { return stripDict(stripOf(d, key)); }, py::arg("key"),
          "A strip by index or id: dict of time_s (n,), r_s (n, 3), x_m (n, 3), and laser, intensity where loaded (copies).")
      .def(
          "points",
          [](const PyData& d, const py::object& key, const MountingParameters& mounting) {
            const StripData& s = stripOf(d, key);
            std::vector<Vec3> x;
            {
              py::gil_scoped_release release;
              x = georeferencedStrip(d.loaded->data, s, mounting);
            }
            return fromVec3s(x);
          },
          py::arg("key"), py::arg("mounting"),
          "A strip's points (n, 3) georeferenced with `mounting` at their own poses (per-point or from the trajectory).")
      .def_property_readonly("trajectory",
                             [](const PyData& d) -> py::object {
                               if (!d.loaded->data.trajectory) return py::none();
                               return py::cast(std::make_shared<Trajectory>(*d.loaded->data.trajectory));
                             })
      .def_property_readonly("mounting_used", [](const PyData& d) { return d.loaded->data.mounting_used; })
      .def_property_readonly("job", [](const PyData& d) { return std::const_pointer_cast<Job>(d.job); });

  m.def(
      "load_job_trajectory",
      [](const std::shared_ptr<Job>& job) {
        if (!job) throw py::value_error("job: None");
        if (job->per_point_poses) throw InvalidInput(job->path + ": the job takes per-point poses from its strips; it names no trajectory");
        std::shared_ptr<const Trajectory> t;
        {
          py::gil_scoped_release release;
          t = loadJobTrajectory(*job).data.trajectory;
        }
        return std::make_shared<Trajectory>(*t);
      },
      py::arg("job"), "The job's trajectory alone (no strips), in its computation frame (local; a CRS job's ENU tangent frame).");
  m.def(
      "load_job_data",
      [](const std::shared_ptr<Job>& job) {
        if (!job) throw py::value_error("job: None");
        std::shared_ptr<const LoadedJob> loaded;
        {
          py::gil_scoped_release release;
          loaded = std::make_shared<LoadedJob>(loadJob(*job));
        }
        return PyData{job, loaded};
      },
      py::arg("job"), "Reads the trajectory, strips and inputs a job names (loadJob).");
}

/// Summary as Python sees it: the C++ summary and its result file's text (written once, with it).
struct PySummary {
  std::shared_ptr<const MountingCalibrator::Summary> s;
  std::string result_json;  ///< resultJson(*s)
};

void bindSummary(py::module_& m) {
  using S = PySummary;
  py::class_<S>(m, "Summary", "A calibration's result: the mounting, its σ and correlations, the verdict and each kind's residuals.")
      .def_property_readonly("mounting", [](const S& x) { return x.s->mounting; })
      .def_property_readonly("mounting_used", [](const S& x) { return x.s->mounting_used; })
      .def_property_readonly(
          "parameter_names",
          [](const S&) { return std::vector<std::string>(mountingParameterNames().begin(), mountingParameterNames().end()); })
      .def_property_readonly("estimated", [](const S& x) { return std::vector<bool>(x.s->estimated.begin(), x.s->estimated.end()); })
      .def_property_readonly(
          "values", [](const S& x) { return sixInUnits(x.s->mounting.toArray()); },
          "The six parameters [m, m, m, deg, deg, deg] (lever arm x, y, z; boresight roll, pitch, heading).")
      .def_property_readonly(
          "sigma", [](const S& x) { return sixInUnits(x.s->sigma); }, "σ [m, m, m, deg, deg, deg]; NaN where not estimated.")
      .def_property_readonly(
          "formal_sigma", [](const S& x) { return sixInUnits(x.s->formal_sigma); },
          "The formal σ (independent observations, no trajectory errors in time) [m, deg].")
      .def_property_readonly("sigma_model", [](const S& x) { return x.s->sigma_model; })
      .def_property_readonly("correlation", [](const S& x) { return mat(x.s->correlation); })
      .def_property_readonly(
          "covariance", [](const S& x) { return mat(x.s->covariance); }, "6×6 [m, rad].")
      .def_property_readonly("variance_factor", [](const S& x) { return x.s->variance_factor; })
      .def_property_readonly("degrees_of_freedom", [](const S& x) { return x.s->degrees_of_freedom; })
      .def_property_readonly("unobservable", [](const S& x) { return x.s->unobservable; })
      .def_property_readonly("usable", [](const S& x) { return x.s->IsSolutionUsable(); })
      .def_property_readonly("termination", [](const S& x) { return std::string(toString(x.s->termination)); })
      .def_property_readonly("message", [](const S& x) { return x.s->message; })
      .def_property_readonly("methods", [](const S& x) { return x.s->methods; })
      .def_property_readonly(
          "verdict", [](const S& x) { return std::string(x.s->verdict().name()); }, "'accept', 'doubtful' or 'reject'.")
      .def_property_readonly("verdict_reasons", [](const S& x) { return x.s->verdict().reasons; })
      .def_property_readonly("laser_elevation_offsets_deg",
                             [](const S& x) {
                               std::vector<double> v;
                               for (const LaserCorrection& l : x.s->laserCorrections()) v.push_back(l.elevation_rad * kDeg);
                               return fromVector(v);
                             })
      .def_property_readonly(
          "laser_intrinsics",
          [](const S& x) {
            std::vector<double> e, a, r, v, h;
            for (const LaserCorrection& l : x.s->laserCorrections()) {
              e.push_back(l.elevation_rad * kDeg);
              a.push_back(l.azimuth_rad * kDeg);
              r.push_back(l.range_m);
              v.push_back(l.vertical_m);
              h.push_back(l.horizontal_m);
            }
            return py::dict(py::arg("elevation_deg") = fromVector(e), py::arg("azimuth_deg") = fromVector(a),
                            py::arg("range_m") = fromVector(r), py::arg("vertical_m") = fromVector(v),
                            py::arg("horizontal_m") = fromVector(h));
          },
          "Per-laser intrinsics by laser id (arrays; zero for a group not estimated; empty: none).")
      .def_property_readonly(
          "kinds",
          [](const S& x) {
            py::dict d;
            for (const auto& k : x.s->kinds)
              d[py::str(k.kind)] = py::dict(py::arg("blocks") = k.blocks, py::arg("residuals") = k.residuals);
            return d;
          },
          "Residual blocks and residuals per kind of observation.")
      .def_property_readonly(
          "residuals",
          [](const S& x) {
            // Each kind's section of the result file (SPEC §4), as plain Python values.
            const py::dict r = fromJson(x.result_json);
            py::dict d;
            for (const auto& k : x.s->kinds)
              if (r.contains(k.kind.c_str()) && !r[k.kind.c_str()].is_none()) d[py::str(k.kind)] = r[k.kind.c_str()];
            if (d.contains("ties") && r.contains("residuals")) d["tie_residuals"] = r["residuals"];
            return d;
          },
          "Each kind's residual section of the result file: {kind: dict}.")
      .def(
          "result", [](const S& x) { return fromJson(x.result_json); }, "The result file's content (SPEC §4) without evaluation.")
      .def(
          "report", [](const S& x) { return x.s->FullReport(); }, "The table `mountcal calibrate` prints.")
      .def("__repr__", [](const S& x) { return x.s->BriefReport(); });

  m.def(
      "calibrate",
      [](const PyData& data, const py::object& options) {
        const MountingCalibrator::Options o = options.is_none() ? (data.job ? data.job->options : MountingCalibrator::Options{})
                                                                : options.cast<MountingCalibrator::Options>();
        auto s = std::make_shared<MountingCalibrator::Summary>();
        std::string text;
        {
          py::gil_scoped_release release;
          *s = MountingCalibrator(o).calibrate(data.loaded->data);
          text = resultJson(*s);
        }
        return PySummary{s, std::move(text)};
      },
      py::arg("data"), py::arg("options") = py::none(), "Calibrates the mounting from loaded data; options None: the job's own settings.");

  m.def(
      "calibrate_job",
      [](const std::string& path, const py::kwargs& overrides) {
        std::string text;
        {
          const std::string patch = overrides.empty() ? std::string() : toJson(overrides);
          py::gil_scoped_release release;
          const Job job = readJob(path, patch);
          const LoadedJob loaded = loadJob(job);
          text = calibrateJob(job, loaded).result_json;
        }
        return fromJson(text);
      },
      py::arg("path"),
      "Calibrates a job as `mountcal calibrate` does and returns the result file's content as a dict (writes nothing). "
      "Keyword arguments override the job's top-level keys.");
}

}  // namespace

void bindStrips(py::module_& m);  // strips.cpp

PYBIND11_MODULE(_mountcal, m) {
  m.doc() = "mountcal: LiDAR mounting (lever arm and boresight) calibration from overlapping strips.";
  m.attr("__version__") = MOUNTCAL_VERSION_STRING;
  bindExceptions(m);
  bindGeometry(m);
  bindGeoreferencing(m);
  bindJobs(m);
  bindSummary(m);
  bindStrips(m);
  m.def("presets", &simulation::presetNames, "The simulator's built-in presets.");
  m.def(
      "simulate",
      [](const std::string& preset, std::uint64_t seed, const std::string& out, bool noise, bool ties, bool laz, const std::string& crs) {
        py::gil_scoped_release release;
        simulation::SurveyConfig config;
        simulation::Scene scene;
        simulation::makePreset(preset, seed, &config, &scene);
        if (!noise) config.noise = simulation::NoiseModel::none();
        SurveyWriteOptions w;
        w.crs = crs;
        w.ties = ties;
        w.laz = laz;
        checkSurveyWriteOptions(w);  // before the survey is simulated
        const simulation::SimulatedSurvey survey = simulation::simulate(config, scene);
        const std::string empty = stripWithoutPoints(survey);
        if (!empty.empty())
          throw InvalidInput("preset " + preset + ": strip " + empty + " has no point on the ground (check the mountings and the flight)");
        writeSurvey(survey, out, w);
        return out + "/job.json";
      },
      py::arg("preset"), py::arg("seed") = 1, py::kw_only(), py::arg("out"), py::arg("noise") = true, py::arg("ties") = true,
      py::arg("laz") = false, py::arg("crs") = "",
      "Simulates a preset survey into folder `out` (job.json, strips, trajectory, ties, truth.json) as `mountcal simulate`; returns the "
      "job's path.");
}
