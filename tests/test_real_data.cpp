// Real data of SPEC §5, read from ../shared/data: skipped with a message when absent on a
// developer's machine, a failure when absent in CI (CI=true, as `.ci/run` runs).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "real_data.hpp"

#include <Eigen/Eigenvalues>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>
#include <sstream>

#include "mountcal/core/error.hpp"
#include "mountcal/core/georeference_model.hpp"
#include "mountcal/io/crs.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/core/geodesy.hpp"
#include "mountcal/io/sbet.hpp"

using namespace mountcal;
namespace fs = std::filesystem;

// Both records against PDAL's own published values (PDAL test/unit/io/SbetReaderTest.cpp,
// checkPoint: the 17 fields in SI units and radians, 16 significant digits) — to those digits.
// (SPEC §5 restates record 0 in degrees; its latitude 32.545149° is a slip: PDAL's
// 0.5680211852972264 rad is 32.5452166°, and the other fields of the SPEC agree with PDAL's.)
TEST(RealData, PdalTwoPointSbetReproducesTheExpectedValues) {
  REQUIRE_DATA("pdal/2-points.sbet");
  const auto r = io::readSbet(dataFile("pdal/2-points.sbet"));
  ASSERT_EQ(r.size(), 2u);
  const double pdal[2][17] = {
      {1.516310028360710e+05, 5.680211852972264e-01, -2.041654392303940e+00, 1.077152953296560e+02, -2.332420866600025e+00,
       -3.335067504871401e-01, -3.093961631767838e-02, -2.813407149321339e-02, -2.429905393889139e-02, 3.046773230278662e+00,
       -2.198414736922658e-02, 7.859639737752390e-01, 7.849084719295495e-01, -2.978807916450262e-01, 6.226807982589819e-05,
       9.312162756440178e-03, 7.217812320996525e-02},
      {1.516310078318641e+05, 5.680211834722869e-01, -2.041654392034053e+00, 1.077151424357507e+02, -2.336228229691271e+00,
       -3.324663118952635e-01, -3.022948961008987e-02, -2.813856631423094e-02, -2.425215669392169e-02, 3.047131105236811e+00,
       -2.198416007932108e-02, 8.397590491636475e-01, 3.252165276637165e-01, -1.558883225990844e-01, 8.379685112283802e-04,
       7.372886784718076e-03, 7.179027672314571e-02}};
  for (int k = 0; k < 2; ++k) {
    const io::SbetRecord& a = r[static_cast<std::size_t>(k)];
    const double got[17] = {a.time_s,     a.lat_rad, a.lon_rad, a.h_m, a.vx, a.vy, a.vz, a.roll_rad, a.pitch_rad, a.platform_heading_rad,
                            a.wander_rad, a.ax,      a.ay,      a.az,  a.wx, a.wy, a.wz};
    for (int f = 0; f < 17; ++f)
      EXPECT_NEAR(got[f], pdal[k][f], 1e-15 * std::max(1.0, std::abs(pdal[k][f]))) << "record " << k << " field " << f;
  }
  // The SPEC's degrees for record 0 (stated to 6 decimals), latitude aside.
  const io::SbetRecord& a = r[0];
  EXPECT_NEAR(rad2deg(a.lon_rad), -116.978180, 5e-7);
  EXPECT_NEAR(rad2deg(a.roll_rad), -1.611964, 5e-7);
  EXPECT_NEAR(rad2deg(a.pitch_rad), -1.392233, 5e-7);
  EXPECT_NEAR(rad2deg(a.platform_heading_rad), 174.567247, 5e-7);
  EXPECT_NEAR(rad2deg(a.wander_rad), -1.259599, 5e-7);
  EXPECT_NEAR(rad2deg(a.trueHeading()), 174.567247 + 1.259599, 1e-6);
}

// The external anchor of the conventions (SPEC §5): `pdal/sample.csd` holds Optech raw pulses
// (range, scan angle, attitude, GNSS position, boresight), and PDAL's readers.optech
// georeferences the first one to lon −82.554028877408555°, lat 36.534611447321907°,
// h 344.80889224602356 m — a value no mountcal code computed.
//
// The CSD layout (little endian, PDAL io/OptechCommon.hpp): a 2048-byte header ("CSD\0", vendor,
// software, float version, u16 header size, u16 GPS week, f64 min/max time, u32 records, u16
// strips, 256 u32 strip pointers, f64 misalignment[3] and IMU offsets[3] [rad], temperature,
// pressure, 830 free bytes), then 69-byte pulses: f64 time, u8 returns, f32 range[4],
// u16 intensity[4], f32 scan angle, roll, pitch, heading [rad], f64 lat, lon [rad], f32 h.
//
// Optech's frames, translated by hand into ours: its body frame is (right, forward, up) and its
// local level ENU; with S = [[0,1,0],[1,0,0],[0,0,−1]] (which is also our R_mn for ENU ← NED),
// S·M_optech(r, p, h)·S = Rz(h)·Ry(p)·Rx(r) exactly, so its roll, pitch, heading are our
// R_nb's, its boresight matrix M_optech(misalignment + IMU offsets) is our R_bore of those sums,
// and its scanner vector (ρ sin θ, 0, −ρ cos θ) is our r_s = (0, ρ sin θ, ρ cos θ). No lever arm.
// PDAL then adds the ENU offset to the GNSS point to first order (E/(N cos φ), N/M, U);
// mountcal's geodetic frame is exact, and differs from that by the flat-earth error.
namespace {
template <typename T>
T csdField(const std::vector<char>& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}
}  // namespace

TEST(RealData, OptechCsdFirstPulseGeoreferencesToPdalsPoint) {
  REQUIRE_DATA("pdal/sample.csd");
  std::ifstream in(dataFile("pdal/sample.csd"), std::ios::binary);
  const std::vector<char> csd((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(csd.size(), 71048u);
  ASSERT_EQ(std::string(csd.data(), 3), "CSD");
  const std::size_t header_size = csdField<std::uint16_t>(csd, 104);
  const std::uint32_t records = csdField<std::uint32_t>(csd, 124);
  ASSERT_EQ(header_size, 2048u);
  ASSERT_EQ(header_size + 69u * records, csd.size());
  Vec3 boresight;
  for (int k = 0; k < 3; ++k)
    boresight[k] =
        csdField<double>(csd, 1154 + 8 * static_cast<std::size_t>(k)) + csdField<double>(csd, 1178 + 8 * static_cast<std::size_t>(k));

  struct Pulse {
    double time, range, scan, roll, pitch, heading, lat, lon, h;
  };
  const auto pulse = [&](std::size_t i) {
    const std::size_t o = header_size + 69 * i;
    Pulse p{};
    p.time = csdField<double>(csd, o);
    p.range = csdField<float>(csd, o + 9);  // first return
    p.scan = csdField<float>(csd, o + 33);
    p.roll = csdField<float>(csd, o + 37);
    p.pitch = csdField<float>(csd, o + 41);
    p.heading = csdField<float>(csd, o + 45);
    p.lat = csdField<double>(csd, o + 49);
    p.lon = std::remainder(csdField<double>(csd, o + 57), 2.0 * kPi);  // stored as lon − 2π
    p.h = csdField<float>(csd, o + 65);
    return p;
  };
  const Pulse p0 = pulse(0), p1 = pulse(1);
  ASSERT_EQ(csd[static_cast<std::ptrdiff_t>(header_size) + 8], 1);  // one return

  // The trajectory of the first two pulses' poses, in a tangent frame at the first GNSS point.
  const LocalTangentFrame frame({p0.lat, p0.lon, p0.h});
  std::vector<TrajectorySample> samples;
  for (const Pulse& p : {p0, p1}) {
    TrajectorySample s;
    s.time_s = p.time;
    s.p_m = frame.toLocal({p.lat, p.lon, p.h});
    s.roll = p.roll;
    s.pitch = p.pitch;
    s.heading = p.heading;
    s.R_mn = frame.R_mn(p.lat, p.lon);
    samples.push_back(s);
  }
  MountingParameters mounting;
  mounting.boresight = boresight;
  const GeoreferenceModel model(std::make_shared<const Trajectory>(samples), mounting);
  const Vec3 r_s(0.0, p0.range * std::sin(p0.scan), p0.range * std::cos(p0.scan));
  const Vec3 x_m = model.forward(p0.time, r_s);  // ENU at the GNSS point [m]

  const double lon_expected = -82.554028877408555, lat_expected = 36.534611447321907, h_expected = 344.80889224602356;
  // 1. The same first-order step from ENU to (φ, λ, h) as PDAL: our pulse geometry, frames and
  //    boresight must give its point to rounding (1e-11° ≈ 1 µm).
  const double a = 6378137.0, f = 1.0 / 298.257223563, e2 = f * (2.0 - f);
  const double w = std::sqrt(1.0 - e2 * std::sin(p0.lat) * std::sin(p0.lat));
  const double n_radius = a / w, m_radius = a * (1.0 - e2) / (w * w * w);
  EXPECT_NEAR(rad2deg(p0.lon + x_m.x() / (n_radius * std::cos(p0.lat))), lon_expected, 1e-11);
  EXPECT_NEAR(rad2deg(p0.lat + x_m.y() / m_radius), lat_expected, 1e-11);
  EXPECT_NEAR(p0.h + x_m.z(), h_expected, 1e-6);

  // 2. mountcal's exact geodetic point differs from PDAL's by what the first-order step leaves
  //    out: in height the earth curvature d²/(2R) (the tangent plane rises above the ellipsoid)
  //    for the horizontal distance d from the GNSS point (≈ 4 mm here); horizontally the scale
  //    of the point's height and the curvature, bounded by d·(h + d)/R (≈ 18 mm; 14 mm measured).
  const Geodetic g = frame.toGeodetic(x_m);
  const double d = std::hypot(x_m.x(), x_m.y());
  const double radius = std::sqrt(m_radius * n_radius);
  const double flat_earth = d * d / (2.0 * radius);
  EXPECT_GT(d, 150.0);                                           // the anchor is not a nadir pulse: the scan angle and attitude matter
  EXPECT_NEAR(g.h - h_expected, flat_earth, 0.01 * flat_earth);  // 4.019 mm measured, 4.021 predicted
  const double east_m = deg2rad(rad2deg(g.lon) - lon_expected) * n_radius * std::cos(g.lat);
  const double north_m = deg2rad(rad2deg(g.lat) - lat_expected) * m_radius;
  EXPECT_LT(std::hypot(east_m, north_m), d * (h_expected + d) / radius);
}

TEST(RealData, TruncatedSbetIsRefusedNamingTheFile) {
  REQUIRE_DATA("pdal/badfile.sbet");
  try {
    io::readSbet(dataFile("pdal/badfile.sbet"));
    FAIL() << "badfile.sbet was accepted";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("badfile.sbet"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("not a multiple of the 136-byte"), std::string::npos) << e.what();
  }
}

TEST(RealData, LeewardBodyVectorsLieInOneScanPlaneRotated14DegreesInYaw) {
  REQUIRE_DATA("leeward/points.las");
  REQUIRE_DATA("leeward/sbet.out");
  io::LasHeader h;
  std::vector<io::LasPoint> pts;
  io::readLas(dataFile("leeward/points.las"), &h, &pts);
  ASSERT_EQ(pts.size(), 1325u);
  ASSERT_EQ(h.point_format, 3);
  const auto sbet = io::readSbet(dataFile("leeward/sbet.out"));
  const LocalTangentFrame frame({sbet[0].lat_rad, sbet[0].lon_rad, 0.0});
  const auto traj = std::make_shared<const Trajectory>(io::sbetToTrajectory(dataFile("leeward/sbet.out"), sbet, frame));
  const io::CrsTransform utm("EPSG:32611");
  // Inverse georeferencing with zero mounting: the vector from the IMU in body axes.
  const GeoreferenceModel model(traj, MountingParameters{});
  std::vector<Vec3> u;
  std::vector<double> rank;
  for (const io::LasPoint& p : pts) {
    const Vec3 x_utm(p.X * h.scale[0] + h.offset[0], p.Y * h.scale[1] + h.offset[1], p.Z * h.scale[2] + h.offset[2]);
    const Vec3 x_m = frame.toLocal(utm.toGeodetic(x_utm));
    u.push_back(model.inverse(p.gps_time, x_m).normalized());
    rank.push_back(io::scanAngleDeg(h, p));
  }
  // The scan plane through the sensor: the direction least represented by the vectors.
  Mat3 C = Mat3::Zero();
  for (const Vec3& v : u) C += v * v.transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
  Vec3 n = eig.eigenvectors().col(0);
  if (n.x() < 0) n = -n;
  double ss = 0;
  for (const Vec3& v : u) ss += std::pow(rad2deg(std::asin(n.dot(v))), 2);
  const double sigma_deg = std::sqrt(ss / static_cast<double>(u.size()));
  EXPECT_LE(sigma_deg, 0.012);  // SPEC §5: σ ≈ 0.01°
  // The body y–z plane has normal +x; the scan plane's normal is turned by the yaw.
  const double yaw_deg = rad2deg(std::atan2(n.y(), n.x()));
  EXPECT_NEAR(yaw_deg, 14.0, 1.0) << "normal " << n.transpose();
  // Across-track angles in the scan plane against the LAS scan-angle rank (positive right).
  const Mat3 R_sb = Rz(deg2rad(yaw_deg)).transpose();
  std::vector<double> d;
  for (std::size_t i = 0; i < u.size(); ++i) {
    const Vec3 s = R_sb * u[i];
    d.push_back(rad2deg(std::atan2(s.y(), s.z())) - rank[i]);
  }
  double mean = 0, ss_d = 0;
  for (double x : d) mean += x / static_cast<double>(d.size());
  for (double x : d) ss_d += (x - mean) * (x - mean);
  const double rms = std::sqrt(ss_d / static_cast<double>(d.size()));
  EXPECT_LT(std::abs(mean), 1.0);
  // Point by point, not only on average. The rank is rounded to whole degrees (a uniform ±0.5°
  // rounding alone gives an RMS of 0.289°); measured: mean 0.17°, RMS 0.52° — the part beyond
  // the rounding is not explained here (the aircraft's roll, which the rank includes, changes
  // it by < 0.01° over this second). The bound holds the measured agreement.
  EXPECT_LT(rms, 0.6) << "mean " << mean;
  std::printf("leeward: scan-plane sigma %.4f deg, yaw %.3f deg, scan angle - rank: mean %.3f, RMS %.3f deg\n", sigma_deg, yaw_deg, mean,
              rms);
}

TEST(RealData, LasRoundTripKeepsEveryFieldBitIdentical) {
  REQUIRE_DATA("leeward/points.las");
  io::LasHeader h;
  std::vector<io::LasPoint> pts;
  io::readLas(dataFile("leeward/points.las"), &h, &pts);
  const std::string out = (fs::temp_directory_path() / "mountcal_roundtrip.las").string();
  io::writeLas(out, h, pts);
  io::LasHeader h2;
  std::vector<io::LasPoint> pts2;
  io::readLas(out, &h2, &pts2);
  ASSERT_EQ(pts.size(), pts2.size());
  EXPECT_EQ(h2.point_format, h.point_format);
  EXPECT_EQ(h2.version_minor, h.version_minor);
  EXPECT_EQ(h2.global_encoding, h.global_encoding);
  ASSERT_EQ(h2.vlrs.size(), h.vlrs.size());
  for (std::size_t i = 0; i < h.vlrs.size(); ++i) {
    EXPECT_EQ(h2.vlrs[i].user_id, h.vlrs[i].user_id);
    EXPECT_EQ(h2.vlrs[i].record_id, h.vlrs[i].record_id);
    EXPECT_EQ(h2.vlrs[i].data, h.vlrs[i].data);
  }
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const auto &a = pts[i], &b = pts2[i];
    ASSERT_TRUE(a.X == b.X && a.Y == b.Y && a.Z == b.Z && a.intensity == b.intensity && a.return_number == b.return_number &&
                a.number_of_returns == b.number_of_returns && a.scan_direction == b.scan_direction &&
                a.edge_of_flight_line == b.edge_of_flight_line && a.classification == b.classification && a.scan_angle == b.scan_angle &&
                a.user_data == b.user_data && a.point_source_id == b.point_source_id && std::memcmp(&a.gps_time, &b.gps_time, 8) == 0 &&
                a.red == b.red && a.green == b.green && a.blue == b.blue && a.extra == b.extra)
        << "point " << i;
  }
  // The point records themselves are byte-identical to the original file's.
  std::ifstream fa(dataFile("leeward/points.las"), std::ios::binary), fb(out, std::ios::binary);
  std::stringstream sa, sb;
  sa << fa.rdbuf();
  sb << fb.rdbuf();
  const std::string A = sa.str(), B = sb.str();
  const std::size_t n = pts.size() * h.point_record_length;
  EXPECT_EQ(A.substr(A.size() - n), B.substr(B.size() - n));
  fs::remove(out);
}

TEST(Geodesy, EcefRoundTripAndFrames) {
  const Geodetic g{deg2rad(32.5), deg2rad(-117.0), 6991.6};
  const Geodetic back = ecefToGeodetic(geodeticToEcef(g));
  EXPECT_NEAR(back.lat, g.lat, 1e-13);
  EXPECT_NEAR(back.lon, g.lon, 1e-13);
  EXPECT_NEAR(back.h, g.h, 1e-8);
  // At the origin, NED maps to the local ENU exactly as R_mn_local().
  const LocalTangentFrame f(g);
  EXPECT_LT((f.R_mn(g.lat, g.lon) - R_mn_local()).norm(), 1e-15);
  // 10 km east the navigation frame is turned by the meridian convergence (≈ Δλ·sin φ).
  const Geodetic east{g.lat, g.lon + 10000.0 / (6378137.0 * std::cos(g.lat)), g.h};
  const Mat3 R = f.R_mn(east.lat, east.lon);
  const double convergence = rad2deg(std::atan2(R(0, 0), R(1, 0)));  // north's azimuth from grid north
  EXPECT_NEAR(std::abs(convergence), rad2deg(10000.0 / 6378137.0 / std::cos(g.lat) * std::sin(g.lat)), 2e-3);
  EXPECT_GT(std::abs(convergence), 0.05);  // larger than the boresight precision: no flat earth
  EXPECT_THROW(io::CrsTransform("EPSG:999999"), InvalidInput);
}

TEST(RealData, GravityExtraBytesAreNamedTypedAttributes) {
  // Truck.las (ARMO's Gravity data, SPEC §5): an Extra Bytes VLR of 2112 bytes = 11 descriptors
  // of 192 bytes, 57 extra bytes per point (91-byte records of format 3, whose standard part is
  // 34 bytes): frameNo (long, 4) + SensorX/Y/Z and roll/pitch/yaw (double, 6 × 8) + LASzip's
  // LAS 1.4 compatibility fields (short + 3 × uchar) = 4 + 48 + 2 + 3 = 57.
  REQUIRE_DATA("gravity/Truck.las");
  io::LasHeader h;
  std::vector<io::LasPoint> pts;
  io::readLas(dataFile("gravity/Truck.las"), &h, &pts);
  ASSERT_EQ(h.extraBytesPerPoint(), 57);
  const auto attrs = io::extraBytesAttributes(h, dataFile("gravity/Truck.las"));
  ASSERT_EQ(attrs.size(), 11u);
  const char* names[] = {"frameNo", "SensorX", "SensorY", "SensorZ", "SensorRollRads", "SensorPitchRads", "SensorYawRads"};
  const std::size_t offsets[] = {0, 4, 12, 20, 28, 36, 44};
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(attrs[static_cast<std::size_t>(i)].name, names[i]);
    EXPECT_EQ(attrs[static_cast<std::size_t>(i)].byte_offset, offsets[i]) << names[i];
  }
  EXPECT_EQ(attrs[0].data_type, 6);   // long
  EXPECT_EQ(attrs[1].data_type, 10);  // double
  EXPECT_EQ(attrs.back().byte_offset + attrs.back().size, 57u);
  const auto* fx = io::findExtraBytesAttribute(attrs, "SensorX");
  const auto* fz = io::findExtraBytesAttribute(attrs, "SensorZ");
  const auto* roll = io::findExtraBytesAttribute(attrs, "SensorRollRads");
  const auto* frame = io::findExtraBytesAttribute(attrs, "frameNo");
  ASSERT_TRUE(fx && fz && roll && frame);
  EXPECT_EQ(io::findExtraBytesAttribute(attrs, "nope"), nullptr);
  // Physical sense of every point's pose: the UAV flies 10–40 m above the truck it scans,
  // within 60 m in plan, level within 0.5 rad; frames are whole numbers.
  double f_min = 1e300, f_max = -1e300;
  for (const io::LasPoint& p : pts) {
    const double x = p.X * h.scale[0] + h.offset[0], z = p.Z * h.scale[2] + h.offset[2];
    const double sx = io::extraBytesValue(p, *fx), sz = io::extraBytesValue(p, *fz), r = io::extraBytesValue(p, *roll);
    ASSERT_LT(std::abs(sx - x), 60.0);
    ASSERT_GT(sz - z, 10.0);
    ASSERT_LT(sz - z, 40.0);
    ASSERT_LT(std::abs(r), 0.5);
    const double f = io::extraBytesValue(p, *frame);
    ASSERT_EQ(f, std::floor(f));
    f_min = std::min(f_min, f);
    f_max = std::max(f_max, f);
  }
  EXPECT_GT(f_max - f_min, 100);  // two passes, separate frame ranges
  EXPECT_THROW(io::extraBytesValue(pts[0], *fx, 1), InvalidInput);
}
