// mountcal.read_strip / read_las_header: LAS and LAZ files (the library's own reader, io/las.hpp)
// to NumPy columns, the documented extra bytes as named columns.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "mountcal/core/error.hpp"
#include "mountcal/io/las.hpp"

namespace py = pybind11;
using namespace mountcal;

namespace {

py::dict headerDict(const io::LasReader& r, const std::vector<io::ExtraBytesAttribute>& extra) {
  const io::LasHeader& h = r.header();
  py::dict d;
  d["version"] = std::to_string(h.version_major) + "." + std::to_string(h.version_minor);
  d["point_format"] = int{h.point_format};
  d["point_record_length"] = int{h.point_record_length};
  d["point_count"] = h.point_count;
  d["scale"] = h.scale;
  d["offset"] = h.offset;
  d["min"] = h.min;
  d["max"] = h.max;
  d["system_identifier"] = h.system_identifier;
  d["generating_software"] = h.generating_software;
  d["global_encoding"] = int{h.global_encoding};
  d["adjusted_standard_gps_time"] = h.adjustedStandardGpsTime();
  d["compressed"] = r.laz() != nullptr;
  py::list names;
  for (const auto& a : extra) names.append(a.name);
  d["extra_bytes"] = names;
  py::list vlrs;
  for (const io::LasVlr& v : h.vlrs)
    vlrs.append(py::dict(py::arg("user_id") = v.user_id, py::arg("record_id") = int{v.record_id}, py::arg("description") = v.description,
                         py::arg("length") = v.data.size()));
  d["vlrs"] = vlrs;
  return d;
}

/// One output column: a NumPy array of the file's point count and how a point fills its row.
struct Column {
  std::string name;
  py::array array;
  std::function<void(const io::LasReader&, const io::LasPoint&, std::size_t row, void* data)> fill;
};

template <class T>
Column column(const std::string& name, std::size_t n, std::function<T(const io::LasReader&, const io::LasPoint&)> get, int width = 1) {
  Column c;
  c.name = name;
  c.array = width == 1 ? py::array(py::array_t<T>(static_cast<py::ssize_t>(n)))
                       : py::array(py::array_t<T>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(width)}));
  c.fill = [get](const io::LasReader& r, const io::LasPoint& p, std::size_t row, void* data) { static_cast<T*>(data)[row] = get(r, p); };
  return c;
}

std::vector<Column> columnsOf(const io::LasReader& r, const std::vector<io::ExtraBytesAttribute>& extra, std::size_t n) {
  using R = const io::LasReader&;
  using P = const io::LasPoint&;
  const io::LasHeader& h = r.header();
  const bool extended = h.point_format >= 6;
  std::vector<Column> c;
  c.push_back(column<double>("x", n, [](R rd, P p) { return rd.x(p); }));
  c.push_back(column<double>("y", n, [](R rd, P p) { return rd.y(p); }));
  c.push_back(column<double>("z", n, [](R rd, P p) { return rd.z(p); }));
  c.push_back(column<std::uint16_t>("intensity", n, [](R, P p) { return p.intensity; }));
  c.push_back(column<std::uint8_t>("return_number", n, [](R, P p) { return p.return_number; }));
  c.push_back(column<std::uint8_t>("number_of_returns", n, [](R, P p) { return p.number_of_returns; }));
  // Formats 0–5 keep three flags in the classification byte's high bits (LAS 1.4 R15, table 8).
  c.push_back(column<std::uint8_t>(
      "classification", n, [extended](R, P p) { return extended ? p.classification : static_cast<std::uint8_t>(p.classification & 31u); }));
  c.push_back(column<std::uint8_t>("classification_flags", n, [extended](R, P p) {
    return extended ? p.classification_flags : static_cast<std::uint8_t>(p.classification >> 5);
  }));
  c.push_back(column<bool>("scan_direction", n, [](R, P p) { return p.scan_direction; }));
  c.push_back(column<bool>("edge_of_flight_line", n, [](R, P p) { return p.edge_of_flight_line; }));
  c.push_back(column<double>("scan_angle_deg", n, [](R rd, P p) { return io::scanAngleDeg(rd.header(), p); }));
  c.push_back(column<std::uint8_t>("user_data", n, [](R, P p) { return p.user_data; }));
  c.push_back(column<std::uint16_t>("point_source_id", n, [](R, P p) { return p.point_source_id; }));
  if (extended) c.push_back(column<std::uint8_t>("scanner_channel", n, [](R, P p) { return p.scanner_channel; }));
  if (h.hasGpsTime()) c.push_back(column<double>("gps_time", n, [](R, P p) { return p.gps_time; }));
  if (h.hasRgb()) {
    c.push_back(column<std::uint16_t>("red", n, [](R, P p) { return p.red; }));
    c.push_back(column<std::uint16_t>("green", n, [](R, P p) { return p.green; }));
    c.push_back(column<std::uint16_t>("blue", n, [](R, P p) { return p.blue; }));
  }
  if (h.point_format == 8) c.push_back(column<std::uint16_t>("nir", n, [](R, P p) { return p.nir; }));
  // Documented extra bytes: one float64 column each (scale and offset applied), (n, k) for arrays.
  for (const io::ExtraBytesAttribute& a : extra) {
    if (a.data_type == 0) continue;  // undocumented bytes: in "extra_bytes" below
    for (const Column& existing : c)
      if (existing.name == a.name)
        throw InvalidInput(r.path() + ": extra bytes attribute '" + a.name + "' has the name of a standard field");
    Column col;
    col.name = a.name;
    const int k = a.elements;
    col.array = k == 1 ? py::array(py::array_t<double>(static_cast<py::ssize_t>(n)))
                       : py::array(py::array_t<double>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(k)}));
    col.fill = [a, k](R, P p, std::size_t row, void* data) {
      for (int e = 0; e < k; ++e)
        static_cast<double*>(data)[row * static_cast<std::size_t>(k) + static_cast<std::size_t>(e)] = io::extraBytesValue(p, a, e);
    };
    c.push_back(std::move(col));
  }
  const std::size_t nbytes = h.extraBytesPerPoint();
  if (nbytes > 0) {  // every extra byte as stored, documented or not
    Column raw;
    raw.name = "extra_bytes";
    raw.array = py::array_t<std::uint8_t>({static_cast<py::ssize_t>(n), static_cast<py::ssize_t>(nbytes)});
    raw.fill = [nbytes](R, P p, std::size_t row, void* data) {
      if (p.extra.size() == nbytes) std::memcpy(static_cast<std::uint8_t*>(data) + row * nbytes, p.extra.data(), nbytes);
    };
    c.push_back(std::move(raw));
  }
  return c;
}

}  // namespace

void bindStrips(py::module_& m) {
  m.def(
      "read_las_header",
      [](const std::string& path) {
        io::LasReader r(path);
        return headerDict(r, io::extraBytesAttributes(r.header(), path));
      },
      py::arg("path"), "The header of a LAS or LAZ file as a dict (format, counts, scale, offset, bounds, extra bytes, VLRs).");

  m.def(
      "read_strip",
      [](const std::string& path) {
        std::unique_ptr<io::LasReader> r;
        {
          py::gil_scoped_release release;
          r = std::make_unique<io::LasReader>(path);
        }
        const std::vector<io::ExtraBytesAttribute> extra = io::extraBytesAttributes(r->header(), path);
        const auto n = static_cast<std::size_t>(r->header().point_count);
        std::vector<Column> cols = columnsOf(*r, extra, n);
        std::vector<void*> data;
        for (Column& c : cols) data.push_back(c.array.mutable_data());
        {
          py::gil_scoped_release release;  // fills the arrays' own buffers; no Python object touched
          std::vector<io::LasPoint> chunk;
          std::size_t row = 0;
          while (const std::size_t got = r->read(&chunk)) {
            if (row + got > n) throw FileError(path, "", "more point records than the header's count");
            for (std::size_t i = 0; i < got; ++i)
              for (std::size_t k = 0; k < cols.size(); ++k) cols[k].fill(*r, chunk[i], row + i, data[k]);
            row += got;
          }
          if (row != n)
            throw FileError(path, "", "the header counts " + std::to_string(n) + " points, the file holds " + std::to_string(row));
        }
        py::dict out;
        for (const Column& c : cols) out[py::str(c.name)] = c.array;
        return out;
      },
      py::arg("path"),
      "Every point of a LAS or LAZ file as a dict of NumPy columns: x, y, z [m], intensity, return_number, number_of_returns, "
      "classification, classification_flags, scan_direction, edge_of_flight_line, scan_angle_deg, user_data, point_source_id, "
      "scanner_channel (formats 6+), gps_time, red/green/blue/nir where the format has them, each documented extra-bytes "
      "attribute by its name (float64, scale and offset applied; (n, k) for arrays), and extra_bytes (n, bytes) as stored.");
}
