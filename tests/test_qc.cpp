// Swath-to-swath quality control (issue 29): the statistics against values computed by hand from
// synthetic strips, the smooth-open gates, the GeoTIFF read back through GDAL, and the command.
#include <gtest/gtest.h>

#include <gdal_priv.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mountcal/io/geotiff.hpp"
#include "mountcal/report/swath_qc.hpp"
#include "support.hpp"

namespace mountcal {
namespace {
using mountcal_tests::CommandRun;
using mountcal_tests::runCli;

/// Points on a 0.5 m grid over [x0, x1] × [y0, y1] at heights z(x, y).
template <typename Z>
std::vector<Vec3> gridStrip(double x0, double x1, double y0, double y1, Z z) {
  std::vector<Vec3> out;
  for (double x = x0; x <= x1 + 1e-9; x += 0.5)
    for (double y = y0; y <= y1 + 1e-9; y += 0.5) out.emplace_back(x, y, z(x, y));
  return out;
}

/// Cells of 5 m for dZ and the plane measures, without the point-to-plane measure (the roof tests).
SwathQcOptions roofOptions() {
  SwathQcOptions o;
  o.cell_size_m = 5.0;
  o.plane_cell_m = 5.0;
  o.point_to_plane = false;
  return o;
}

// Two flat strips overlapping on [50, 100] × [0, 100], the second 5 cm higher and tilted by
// 1 mm/m in x: on 5 m cells every overlap cell's dZ is −(0.05 + 0.001 x_c), x_c = 52.5 … 97.5 —
// 10 columns × 20 rows (the cells on the strips' last row and column hold one line of points and
// are not covered). RMSDz, mean and largest |dZ| by hand from those 200 values.
TEST(SwathQc, FlatStripsWithAKnownOffsetAndTiltGiveTheHandStatistics) {
  const std::vector<Vec3> a = gridStrip(0, 100, 0, 100, [](double, double) { return 0.0; });
  const std::vector<Vec3> b = gridStrip(50, 150, 0, 100, [](double x, double) { return 0.05 + 0.001 * x; });
  SwathQcOptions o;
  o.cell_size_m = 5.0;
  const SwathQcResult qc = swathQcOfPoints({"a", "b"}, {a, b}, {a, b}, o);
  ASSERT_EQ(qc.pairs.size(), 1u);
  double ss = 0, sum = 0;
  for (int k = 0; k < 10; ++k) {
    const double dz = -(0.05 + 0.001 * (52.5 + 5 * k));
    ss += 20 * dz * dz;
    sum += 20 * dz;
  }
  const DzStats& s = qc.pairs[0].after;
  EXPECT_EQ(s.cells, 200u);
  EXPECT_NEAR(s.rmsdz_m, std::sqrt(ss / 200), 1e-9);
  EXPECT_NEAR(s.mean_dz_m, sum / 200, 1e-9);
  EXPECT_NEAR(s.max_abs_dz_m, 0.05 + 0.001 * 97.5, 1e-9);
  // Shares beyond 0.04, 0.08 and 0.16 m: all 200, the columns with 0.05 + 0.001 x_c > 0.08 (x_c ≥ 32.5: all), none.
  ASSERT_EQ(s.share_over.size(), 3u);
  EXPECT_DOUBLE_EQ(s.share_over[0], 1.0);
  EXPECT_DOUBLE_EQ(s.share_over[1], 1.0);
  EXPECT_DOUBLE_EQ(s.share_over[2], 0.0);
  // Flat and noise-free: every strip's precision is 0 and the raster is 10 × 20 of those values.
  EXPECT_NEAR(qc.strips[0].intraswath_precision_m, 0.0, 1e-9);
  EXPECT_EQ(qc.pairs[0].raster_after.nx, 10);
  EXPECT_EQ(qc.pairs[0].raster_after.ny, 20);
  EXPECT_NEAR(qc.pairs[0].raster_after.x0_m, 50.0, 1e-12);
  EXPECT_NEAR(qc.pairs[0].raster_after.y1_m, 100.0, 1e-12);
  EXPECT_NEAR(qc.pairs[0].raster_after.dz_m[0], -(0.05 + 0.001 * 52.5), 1e-6);  // north-west cell
  // A level that passes these figures and one that does not.
  for (const LevelVerdict& v : qc.verdicts) EXPECT_EQ(v.rmsdz_pass, s.rmsdz_m <= v.level.interswath_rmsdz_m) << v.level.name;
}

// The verdict table: an ASPRS X-cm class is 0.6 / 0.8 / 1.6 × X; its 10-cm and 5-cm classes are
// the USGS QL2 and QL0 limits written in the specification's own table (3/4/8 cm, 6/8/16 cm).
TEST(SwathQc, AsprsClassesMatchTheUsgsLevelsOfTheirAccuracy) {
  const QualityLevel ten = asprsVerticalClass(0.10), five = asprsVerticalClass(0.05);
  const std::vector<QualityLevel> usgs = usgsQualityLevels();
  ASSERT_EQ(usgs.size(), 4u);
  EXPECT_EQ(ten.name, "ASPRS 10-cm");
  EXPECT_NEAR(ten.intraswath_max_m, usgs[2].intraswath_max_m, 1e-12);
  EXPECT_NEAR(ten.interswath_rmsdz_m, usgs[2].interswath_rmsdz_m, 1e-12);
  EXPECT_NEAR(ten.interswath_max_m, usgs[2].interswath_max_m, 1e-12);
  EXPECT_NEAR(five.intraswath_max_m, 0.03, 1e-12);
  EXPECT_NEAR(five.interswath_rmsdz_m, 0.04, 1e-12);
  EXPECT_NEAR(five.interswath_max_m, 0.08, 1e-12);
  EXPECT_EQ(defaultQualityLevels().size(), 11u);
}

// The ASPRS 2018 roof-plane measure: two strips of a 30° roof, the second shifted 10 cm in x
// (horizontally: z_B(x) = tan 30° · (x − 0.1)). No cell is smooth (too steep for dZ); every
// covered cell is planar in both, and B's centroid lies h·sin θ = 0.1 · sin 30° = 0.05 m from A's
// plane along its normal (A above B: +0.05, the sign of dZ = A − B). A hand derivation: the
// vertical gap h·tan θ times cos θ.
TEST(SwathQc, SlopedPlanesShowAHorizontalShiftAsItsSineOfTheSlope) {
  const double t = std::tan(30 * M_PI / 180);
  const std::vector<Vec3> a = gridStrip(0, 100, 0, 100, [&](double x, double) { return t * x; });
  const std::vector<Vec3> b = gridStrip(0, 100, 0, 100, [&](double x, double) { return t * (x - 0.1); });
  SwathQcOptions o = roofOptions();
  const SwathQcResult qc = swathQcOfPoints({"a", "b"}, {a, a}, {a, b}, o);
  ASSERT_EQ(qc.pairs.size(), 1u);
  EXPECT_EQ(qc.pairs[0].after.cells, 0u);                  // dZ: no smooth cell on a 30° roof
  EXPECT_EQ(qc.pairs[0].sloped_planes_after.cells, 400u);  // 20 × 20 covered cells
  EXPECT_NEAR(qc.pairs[0].sloped_planes_after.mean_dz_m, 0.05, 1e-9);
  EXPECT_NEAR(qc.pairs[0].sloped_planes_after.rmsdz_m, 0.05, 1e-9);
  EXPECT_NEAR(qc.pairs[0].sloped_planes_after.max_abs_dz_m, 0.05, 1e-9);
  EXPECT_NEAR(qc.pairs[0].sloped_planes_before.rmsdz_m, 0.0, 1e-9);  // before: the same strip twice
  EXPECT_NEAR(qc.sloped_planes_after.rmsdz_m, 0.05, 1e-9);
  // Steeper than max_plane_slope_deg: not a roof plane (a wall is not a height field).
  o.max_plane_slope_deg = 25;
  EXPECT_EQ(swathQcOfPoints({"a", "b"}, {a, a}, {a, b}, o).pairs.size(), 0u);
  const std::string json = swathQcJson(qc);
  EXPECT_NE(json.find("\"sloped_planes\""), std::string::npos);
  EXPECT_NE(swathQcSection(qc).find("Sloped planes"), std::string::npos);
}

// The ASPRS 2018 roof-edge measure: a gable roof (faces of 30°) whose ridge runs along y at
// x = 52.5 m, in the middle of a 5 m cell; the second strip's ridge 10 cm further east. The cells
// on either side of the ridge cell, [45, 50) and [55, 60) m, are planar in both strips and turn by
// 60°: their planes meet at x = 52.5 in the first strip and at 52.6 in the second — 0.1 m apart
// across the ridge, for every such pair of cells: each of the 20 rows with the rows within two
// of it, 20·5 − 2·(2 + 1) = 94 pairs (by hand).
TEST(SwathQc, RoofEdgesShowAHorizontalShiftAcrossTheRidge) {
  const double t = std::tan(30 * M_PI / 180);
  const std::vector<Vec3> a = gridStrip(0, 100, 0, 100, [&](double x, double) { return 10 - t * std::abs(x - 52.5); });
  const std::vector<Vec3> b = gridStrip(0, 100, 0, 100, [&](double x, double) { return 10 - t * std::abs(x - 52.6); });
  const SwathQcResult qc = swathQcOfPoints({"a", "b"}, {a, a}, {a, b}, roofOptions());
  ASSERT_EQ(qc.pairs.size(), 1u);
  const DzStats& e = qc.pairs[0].roof_edges_after;
  EXPECT_EQ(e.cells, 94u);
  EXPECT_NEAR(e.mean_dz_m, 0.1, 1e-9);
  EXPECT_NEAR(e.max_abs_dz_m, 0.1, 1e-9);
  EXPECT_NEAR(qc.pairs[0].roof_edges_before.rmsdz_m, 0.0, 1e-9);  // before: the same strip twice
  EXPECT_NEAR(qc.roof_edges_after.rmsdz_m, 0.1, 1e-9);
  // Read back from qc.json and merged: the same figures.
  const SwathQcResult back = mergeSwathQc({swathQcFromJson(swathQcJson(qc))});
  EXPECT_EQ(back.roof_edges_after.cells, 94u);
  EXPECT_NEAR(back.roof_edges_after.rmsdz_m, 0.1, 1e-9);
  EXPECT_NE(swathQcSection(qc).find("Roof edges"), std::string::npos);
}

// The gates: of a field with four kinds of ground — flat, a 20° slope, a rough patch (±15 cm,
// vegetation-like) and a 3 m step (a roof's edge) — only the flat cells are compared, whatever
// the two strips' offset there.
TEST(SwathQc, CellsOnSlopesRoughGroundAndEdgesAreNotCompared) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-0.15, 0.15);
  auto ground = [&](double x, double y) {
    if (x < 25) return 0.0;                            // flat: 5 columns of 5 m cells
    if (x < 50) return std::tan(20 * M_PI / 180) * x;  // slope
    if (x < 75) return u(rng);                         // rough
    return y < 52.5 ? 0.0 : 3.0;                       // a step through the cells of row 10
  };
  const std::vector<Vec3> a = gridStrip(0, 99.5, 0, 99.5, ground);
  std::vector<Vec3> b = gridStrip(0, 99.5, 0, 99.5, ground);
  for (Vec3& p : b) p.z() += 0.02;
  SwathQcOptions o;
  o.cell_size_m = 5.0;
  const SwathQcResult qc = swathQcOfPoints({"a", "b"}, {a, b}, {a, b}, o);
  ASSERT_EQ(qc.pairs.size(), 1u);
  // Flat: x < 25 (5 columns × 20 rows); the step's columns x ≥ 75 away from row 10 are flat too
  // (5 columns × 19 rows). Not the slope, not the rough patch, not the step's row.
  EXPECT_EQ(qc.pairs[0].after.cells, 100u + 95u);
  EXPECT_NEAR(qc.pairs[0].after.rmsdz_m, 0.02, 1e-9);
}

// The raster read back through GDAL: origin, cell size, CRS, values and no-data.
TEST(SwathQc, GeoTiffReadBackHasTheGeoreferencingAndValues) {
  DzRaster r;
  r.x0_m = 500000;
  r.y1_m = 4000100;
  r.cell_m = 2.5;
  r.nx = 3;
  r.ny = 2;
  r.dz_m = {0.01f, -0.02f, std::nanf(""), 0.04f, 0.05f, -0.06f};
  const std::string path = (std::filesystem::temp_directory_path() / ("mountcal_qc_" + std::to_string(::getpid()) + ".tif")).string();
  io::writeGeoTiff(path, r, "EPSG:32633");
  GDALAllRegister();
  GDALDataset* ds = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  ASSERT_NE(ds, nullptr);
  double t[6];
  ASSERT_EQ(ds->GetGeoTransform(t), CE_None);
  EXPECT_DOUBLE_EQ(t[0], 500000);
  EXPECT_DOUBLE_EQ(t[1], 2.5);
  EXPECT_DOUBLE_EQ(t[3], 4000100);
  EXPECT_DOUBLE_EQ(t[5], -2.5);
  EXPECT_EQ(ds->GetRasterXSize(), 3);
  EXPECT_EQ(ds->GetRasterYSize(), 2);
  const OGRSpatialReference* srs = ds->GetSpatialRef();
  ASSERT_NE(srs, nullptr);
  EXPECT_STREQ(srs->GetAuthorityCode(nullptr), "32633");
  GDALRasterBand* band = ds->GetRasterBand(1);
  int has = 0;
  EXPECT_DOUBLE_EQ(band->GetNoDataValue(&has), io::kGeoTiffNoData);
  EXPECT_TRUE(has);
  std::vector<float> v(6);
  ASSERT_EQ(band->RasterIO(GF_Read, 0, 0, 3, 2, v.data(), 3, 2, GDT_Float32, 0, 0), CE_None);
  EXPECT_FLOAT_EQ(v[0], 0.01f);
  EXPECT_FLOAT_EQ(v[1], -0.02f);
  EXPECT_FLOAT_EQ(v[2], static_cast<float>(io::kGeoTiffNoData));
  EXPECT_FLOAT_EQ(v[5], -0.06f);
  GDALClose(ds);
  std::filesystem::remove(path);
}

// The command on the simulated crossing field before and after calibration: qc.json with the
// pairs' before and after, RMSDz falling almost tenfold (the mounting error is 0.1–0.2°),
// the rasters and the report written; a missing output folder is exit 2 with one line.
TEST(SwathQc, CommandWritesTheFilesAndTheCalibrationLowersRmsdz) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("mountcal_qc_cli_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "out");
  ASSERT_EQ(runCli("simulate --preset paper-calibration-field --seed 2 --out " + (dir / "f").string()).code, 0);
  ASSERT_EQ(runCli("calibrate --quiet " + (dir / "f" / "job.json").string()).code, 0);
  const CommandRun r = runCli("qc " + (dir / "f" / "job.json").string() + " --result " + (dir / "f" / "result.json").string() + " --out " +
                              (dir / "out").string());
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(dir / "out" / "qc.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_FALSE(j["pairs"].empty());
  const double before = j["summary"]["before"]["rmsdz_m"], after = j["summary"]["rmsdz_m"];
  // What stays is the strips' GNSS errors (1.5 cm per axis, Gauss–Markov 100 s), which no
  // mounting removes: 0.0207 m against 0.2045 m before on this seed.
  EXPECT_LT(after, 0.15 * before) << r.out;
  EXPECT_LT(after, 0.03);
  EXPECT_EQ(j["strips"].size(), 4u);
  EXPECT_EQ(j["summary"]["classes"].size(), 11u);  // USGS QL0–QL3, ASPRS 1 … 33.3 cm
  // The roofs (the sloped-plane measure): smeared before, centimetres after.
  const nlohmann::json& planes = j["summary"]["sloped_planes"];
  EXPECT_GE(planes["after"]["cells"].get<int>(), 10) << r.out;
  EXPECT_LT(planes["after"]["rms_m"].get<double>(), 0.03) << r.out;
  if (planes["before"]["cells"].get<int>() > 0) {
    EXPECT_GT(planes["before"]["rms_m"].get<double>(), 0.1) << r.out;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "qc.html"));
  EXPECT_TRUE(std::filesystem::exists(dir / "out" / "dz_1_2_after.tif"));
  const CommandRun bad = runCli("qc " + (dir / "f" / "job.json").string() + " --out " + (dir / "missing").string());
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("missing"), std::string::npos) << bad.err;
  // qc-summary: a file that is not a pair's qc.json (the job) is refused with its name, and the
  // summary never replaces one of its inputs.
  const CommandRun not_qc = runCli("qc-summary " + (dir / "f" / "job.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(not_qc.code, 2);
  EXPECT_NE(not_qc.err.find("job.json"), std::string::npos) << not_qc.err;
  const CommandRun over = runCli("qc-summary " + (dir / "out" / "qc.json").string() + " --out " + (dir / "out").string());
  EXPECT_EQ(over.code, 2);
  EXPECT_NE(over.err.find("would overwrite an input"), std::string::npos) << over.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mountcal
