// LAS reader/writer against the ASPRS layout: every supported format, extra bytes, VLRs,
// EVLRs, both scan-angle forms, streaming, and malformed headers.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "mountcal/core/error.hpp"
#include "mountcal/io/las.hpp"
#include "mountcal/io/las_crs.hpp"
#include "mountcal/io/pose_fields.hpp"
#include "support.hpp"

using namespace mountcal_tests;
using namespace mountcal;
using namespace mountcal::io;
namespace fs = std::filesystem;

namespace {

LasHeader header(std::uint8_t format, std::uint8_t minor, int extra) {
  LasHeader h;
  h.version_minor = minor;
  h.point_format = format;
  h.point_record_length = static_cast<std::uint16_t>(LasHeader::standardRecordLength(format) + extra);
  h.global_encoding = format >= 6 ? 1 : 0;
  h.offset = {500000.0, 4000000.0, 0.0};
  h.scale = {0.01, 0.01, 0.001};
  h.vlrs.push_back({"LASF_Projection", 34735, "GeoKeyDirectoryTag", {1, 0, 1, 0, 0, 0, 0, 0}});
  h.vlrs.push_back({"mountcal", 7, "opaque", std::vector<std::uint8_t>(37, 0xAB)});
  if (minor >= 4) h.evlrs.push_back({"mountcal", 8, "big record", std::vector<std::uint8_t>(70000, 0x5A)});
  h.header_padding = {1, 2, 3};
  h.vlr_padding = {0xEE, 0xDD};
  return h;
}

std::vector<LasPoint> points(const LasHeader& h, int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<LasPoint> v(static_cast<std::size_t>(n));
  for (auto& p : v) {
    p.X = static_cast<std::int32_t>(rng() % 200000) - 100000;
    p.Y = static_cast<std::int32_t>(rng() % 200000);
    p.Z = static_cast<std::int32_t>(rng() % 5000);
    p.intensity = static_cast<std::uint16_t>(rng());
    p.return_number = static_cast<std::uint8_t>(1 + rng() % (h.point_format >= 6 ? 15 : 5));
    p.number_of_returns = static_cast<std::uint8_t>(1 + rng() % (h.point_format >= 6 ? 15 : 5));
    p.scan_direction = rng() & 1;
    p.edge_of_flight_line = rng() & 1;
    p.classification = static_cast<std::uint8_t>(rng());
    p.user_data = static_cast<std::uint8_t>(rng());
    p.point_source_id = static_cast<std::uint16_t>(rng());
    if (h.point_format >= 6) {
      p.classification_flags = static_cast<std::uint8_t>(rng() % 16);
      p.scanner_channel = static_cast<std::uint8_t>(rng() % 4);
      p.scan_angle = static_cast<std::int16_t>(static_cast<int>(rng() % 60001) - 30000);
    } else {
      p.scan_angle = static_cast<std::int16_t>(static_cast<int>(rng() % 181) - 90);
    }
    if (h.hasGpsTime()) p.gps_time = 1e8 + (rng() % 1000000) * 1e-3;
    if (h.hasRgb()) {
      p.red = static_cast<std::uint16_t>(rng());
      p.green = static_cast<std::uint16_t>(rng());
      p.blue = static_cast<std::uint16_t>(rng());
    }
    if (h.point_format == 8) p.nir = static_cast<std::uint16_t>(rng());
    p.extra.resize(h.extraBytesPerPoint());
    for (auto& b : p.extra) b = static_cast<std::uint8_t>(rng());
  }
  return v;
}

bool same(const LasPoint& a, const LasPoint& b) {
  return a.X == b.X && a.Y == b.Y && a.Z == b.Z && a.intensity == b.intensity && a.return_number == b.return_number &&
         a.number_of_returns == b.number_of_returns && a.classification_flags == b.classification_flags &&
         a.scanner_channel == b.scanner_channel && a.scan_direction == b.scan_direction && a.edge_of_flight_line == b.edge_of_flight_line &&
         a.classification == b.classification && a.scan_angle == b.scan_angle && a.user_data == b.user_data &&
         a.point_source_id == b.point_source_id && std::memcmp(&a.gps_time, &b.gps_time, 8) == 0 && a.red == b.red && a.green == b.green &&
         a.blue == b.blue && a.nir == b.nir && a.extra == b.extra;
}

}  // namespace

TEST(Las, EveryFormatRoundTripsWithExtraBytesVlrsAndEvlrs) {
  const struct { std::uint8_t format, minor; } cases[] = {{0, 2}, {1, 2}, {2, 3}, {3, 3}, {1, 4}, {6, 4}, {7, 4}, {8, 4}};
  for (const auto& c : cases) {
    const LasHeader h = header(c.format, c.minor, 5);
    const auto pts = points(h, 3000, c.format * 10u + c.minor);
    const std::string a = tempPath("las", "a.las"), b = tempPath("las", "b.las");
    writeLas(a, h, pts);
    LasHeader h2;
    std::vector<LasPoint> back;
    readLas(a, &h2, &back);
    ASSERT_EQ(back.size(), pts.size()) << int(c.format);
    for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_TRUE(same(pts[i], back[i])) << "format " << int(c.format) << " point " << i;
    EXPECT_EQ(h2.version_minor, c.minor);
    EXPECT_EQ(h2.global_encoding, h.global_encoding);
    EXPECT_EQ(h2.point_count, 3000u);
    EXPECT_EQ(h2.extraBytesPerPoint(), 5);
    ASSERT_EQ(h2.vlrs.size(), 2u);
    EXPECT_EQ(h2.vlrs[1].data, h.vlrs[1].data);
    EXPECT_EQ(h2.vlrs[1].description, "opaque");
    EXPECT_EQ(h2.evlrs.size(), h.evlrs.size());
    if (!h.evlrs.empty()) {
      EXPECT_EQ(h2.evlrs[0].data, h.evlrs[0].data);
    }
    EXPECT_EQ(h2.header_padding, h.header_padding);
    EXPECT_EQ(h2.vlr_padding, h.vlr_padding);
    // Bounds and counts by return are computed from the points.
    double zmax = -1e300;
    for (const auto& p : pts) zmax = std::max(zmax, p.Z * h.scale[2] + h.offset[2]);
    EXPECT_DOUBLE_EQ(h2.max[2], zmax);
    // Read → write → read: the whole file is byte-identical.
    writeLas(b, h2, back);
    EXPECT_EQ(slurp(a), slurp(b)) << "format " << int(c.format);
    fs::remove(a);
    fs::remove(b);
  }
}

TEST(Las, ScanAngleInBothFormsAndStreamingInChunks) {
  const LasHeader h6 = header(6, 4, 0), h1 = header(1, 2, 0);
  LasPoint p;
  setScanAngleDeg(h6, -17.5, &p);
  EXPECT_NEAR(scanAngleDeg(h6, p), -17.5, 0.003);  // 0.006° units
  setScanAngleDeg(h1, -17.4, &p);
  EXPECT_EQ(scanAngleDeg(h1, p), -17.0);  // whole degrees (rank)
  const auto pts = points(h6, 10007, 3);
  const std::string a = tempPath("las", "c.las");
  writeLas(a, h6, pts);
  LasReader r(a);
  std::vector<LasPoint> chunk;
  std::size_t total = 0, reads = 0;
  while (r.read(&chunk, 1000) > 0) {
    for (std::size_t i = 0; i < chunk.size(); ++i) ASSERT_TRUE(same(chunk[i], pts[total + i]));
    total += chunk.size();
    ++reads;
  }
  EXPECT_EQ(total, pts.size());
  EXPECT_EQ(reads, 11u);
  fs::remove(a);
}

TEST(Las, MalformedHeadersAreRefusedNamingFileAndByte) {
  const LasHeader h = header(3, 2, 0);
  const std::string a = tempPath("las", "d.las");
  writeLas(a, h, points(h, 10, 4));
  const std::string good = slurp(a);
  auto expectError = [&](std::string bytes, const std::string& what) {
    const std::string p = tempPath("las", "bad.las");
    std::ofstream(p, std::ios::binary) << bytes;
    try {
      LasReader r(p);
      std::vector<LasPoint> chunk;
      while (r.read(&chunk) > 0) {
      }
      ADD_FAILURE() << "accepted: " << what;
    } catch (const FileError& e) {
      EXPECT_EQ(e.path(), p);
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
    fs::remove(p);
  };
  std::string s = good;
  const std::uint16_t short_len = 20;  // format 3 needs 34
  std::memcpy(&s[105], &short_len, 2);
  expectError(s, "shorter than format 3 needs");
  s = good;
  const std::uint32_t huge = 0xFFFFFFFFu;
  std::memcpy(&s[107], &huge, 4);
  expectError(s, "truncated: the header announces");
  s = good;
  const std::uint32_t far_offset = 0xF0000000u;  // found by the fuzzer: once allocated 4 GB
  std::memcpy(&s[96], &far_offset, 4);
  expectError(s, "beyond the end of the file");
  s = good;
  s[104] = 9;
  expectError(s, "format 9 is not supported");
  s = good;
  s[104] = static_cast<char>(0x83);  // compression bits set
  expectError(s, "LAZ");
  s = good;
  s[25] = 7;
  expectError(s, "unsupported LAS version 1.7");
  expectError(good.substr(0, 100), "truncated LAS header");
  s = good;
  s[0] = 'X';
  expectError(s, "signature");
  fs::remove(a);
  // Writing never leaves a half file: a writer that is not closed leaves nothing behind.
  const std::string w = tempPath("las", "unfinished.las");
  {
    LasWriter writer(w, h);
    writer.write(points(h, 5, 1));
  }
  EXPECT_FALSE(fs::exists(w));
}

TEST(Las, ExtraBytesDescriptorsDecodeHandBuiltValues) {
  // A hand-built Extra Bytes VLR (ASPRS LAS 1.4 R15 §2.5.4.2, 192-byte descriptors): a scaled
  // and offset unsigned short "height" and a deprecated 3-element float array "vel", then a
  // point whose extra bytes are written byte by byte.
  io::LasHeader h;
  h.point_format = 6;
  h.point_record_length = static_cast<std::uint16_t>(io::LasHeader::standardRecordLength(6) + 2 + 12);
  std::vector<std::uint8_t> d(2 * 192, 0);
  d[2] = 3;       // unsigned short
  d[3] = 8 | 16;  // scale and offset valid
  std::memcpy(&d[4], "height", 6);
  const double scale = 0.01, offset = 100.0;
  std::memcpy(&d[112], &scale, 8);
  std::memcpy(&d[136], &offset, 8);
  d[192 + 2] = 29;  // deprecated: 3 × float
  std::memcpy(&d[192 + 4], "vel", 3);
  h.vlrs.push_back({"LASF_Spec", 4, "extra bytes", d});
  const auto attrs = io::extraBytesAttributes(h, "hand.las");
  ASSERT_EQ(attrs.size(), 2u);
  EXPECT_EQ(attrs[0].name, "height");
  EXPECT_EQ(attrs[0].size, 2u);
  EXPECT_EQ(attrs[1].byte_offset, 2u);
  EXPECT_EQ(attrs[1].elements, 3);
  EXPECT_EQ(attrs[1].size, 12u);
  io::LasPoint p;
  p.extra.assign(14, 0);
  p.extra[0] = 0x39;  // 12345 = 0x3039, little endian
  p.extra[1] = 0x30;
  const float v[3] = {1.5f, -2.25f, 8.0f};
  std::memcpy(&p.extra[2], v, 12);
  EXPECT_DOUBLE_EQ(io::extraBytesValue(p, attrs[0]), 12345 * 0.01 + 100.0);
  EXPECT_DOUBLE_EQ(io::extraBytesValue(p, attrs[1], 0), 1.5);
  EXPECT_DOUBLE_EQ(io::extraBytesValue(p, attrs[1], 1), -2.25);
  EXPECT_DOUBLE_EQ(io::extraBytesValue(p, attrs[1], 2), 8.0);
  // Malformed: a descriptor count that is not whole, attributes longer than the record, an
  // unknown type — each a FileError naming the file and the descriptor.
  h.vlrs[0].data.resize(200);
  EXPECT_THROW(io::extraBytesAttributes(h, "hand.las"), FileError);
  h.vlrs[0].data = d;
  h.point_record_length = static_cast<std::uint16_t>(io::LasHeader::standardRecordLength(6) + 4);
  try {
    io::extraBytesAttributes(h, "hand.las");
    FAIL() << "no exception";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("hand.las:Extra Bytes descriptor 1 ('vel')"), std::string::npos) << e.what();
  }
  d[2] = 77;
  h.vlrs[0].data = d;
  EXPECT_THROW(io::extraBytesAttributes(h, "hand.las"), FileError);
}

TEST(Las, QuantizeRoundsHalvesAwayFromZeroAndRefusesWhatDoesNotFit) {
  // The writer's quantiser (no library call) against std::round, at halves, near halves, and
  // at the ends of the 32-bit range.
  LasHeader h = header(1, 2, 0);
  h.offset = {100.0, -50.0, 0.0};
  h.scale = {0.01, 0.25, 1.0};
  const std::string path = tempPath("las", "quantize.las");
  {
    LasWriter writer(path, h);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1e6, 1e6);
    for (int i = 0; i < 100000; ++i) {
      const double v = u(rng);
      for (int a = 0; a < 3; ++a) {
        EXPECT_EQ(writer.quantize(a, v), static_cast<std::int32_t>(std::round((v - h.offset[a]) / h.scale[a]))) << v;
      }
    }
    // Exact halves of the stored unit (scale 1, offset 0): away from zero.
    EXPECT_EQ(writer.quantize(2, 2.5), 3);
    EXPECT_EQ(writer.quantize(2, -2.5), -3);
    EXPECT_EQ(writer.quantize(2, 0.49999999999999994), 0);
    EXPECT_EQ(writer.quantize(2, -0.49999999999999994), 0);
    EXPECT_EQ(writer.quantize(2, 2147483647.0), 2147483647);
    EXPECT_EQ(writer.quantize(2, 2147483647.4), 2147483647);
    EXPECT_EQ(writer.quantize(2, -2147483648.0), std::numeric_limits<std::int32_t>::min());
    EXPECT_EQ(writer.quantize(2, -2147483648.4), std::numeric_limits<std::int32_t>::min());
    EXPECT_THROW(writer.quantize(2, 2147483647.5), FileError);
    EXPECT_THROW(writer.quantize(2, -2147483648.5), FileError);
    EXPECT_THROW(writer.quantize(2, std::nan("")), FileError);
    EXPECT_THROW(writer.quantize(2, std::numeric_limits<double>::infinity()), FileError);
    try {
      writer.quantize(2, 1e12, 41);
      FAIL() << "no error";
    } catch (const FileError& e) {
      EXPECT_NE(std::string(e.what()).find("record 41"), std::string::npos) << e.what();
    }
  }
  fs::remove(path);
}

TEST(Las, RecordsWrittenAsStoredGiveTheHeaderOfRecordsWrittenOneByOne) {
  // writeRaw() takes a block's bounds from its extreme stored integers; the reference is the
  // same records through write() one by one (bounds from each point's coordinates), for
  // formats with 3- and 4-bit return numbers (a scale must be positive: the writer says so).
  for (const std::uint8_t format : {std::uint8_t{1}, std::uint8_t{6}}) {
    {
      LasHeader h = header(format, format < 6 ? 2 : 4, 0);
      h.scale = {0.01, 0.25, 0.001};
      std::mt19937 rng(format);
      std::uniform_int_distribution<std::int32_t> coord(-2000000, 2000000);
      std::uniform_int_distribution<int> ret(0, 15);
      std::vector<LasPoint> pts(5000);
      for (LasPoint& p : pts) {
        p.X = coord(rng), p.Y = coord(rng), p.Z = coord(rng);
        p.return_number = static_cast<std::uint8_t>(ret(rng) & (format < 6 ? 7 : 15));
        p.number_of_returns = 7;
        p.gps_time = 1.0;
      }
      const std::string one = tempPath("las", "one_by_one.las"), raw = tempPath("las", "as_stored.las");
      {
        LasWriter w(one, h);
        w.write(pts);
        w.close();
      }
      {
        LasReader r(one);
        std::vector<std::uint8_t> records;
        r.readRaw(&records, pts.size());
        LasWriter w(raw, h);
        w.writeRaw(records.data(), 1234);  // two blocks
        w.writeRaw(records.data() + 1234 * h.point_record_length, pts.size() - 1234);
        w.close();
      }
      const LasHeader a = LasReader(one).header(), b = LasReader(raw).header();
      EXPECT_EQ(a.point_count, b.point_count);
      EXPECT_EQ(a.points_by_return, b.points_by_return);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(a.min[k], b.min[k]) << k;
        EXPECT_EQ(a.max[k], b.max[k]) << k;
      }
      EXPECT_EQ(slurp(one), slurp(raw));
      fs::remove(one);
      fs::remove(raw);
    }
  }
}

TEST(Las, BlockQuantizeEqualsStdRoundAndNamesTheFirstRecordThatDoesNotFit) {
  // apply quantises a block of points at once; the reference is std::round, at random values,
  // exact and near halves, and the ends of the 32-bit range.
  LasHeader h = header(1, 2, 0);
  h.offset = {100.0, -50.0, 0.0};
  h.scale = {0.01, 0.25, 1.0};
  const std::string path = tempPath("las", "quantize_block.las");
  {
    LasWriter writer(path, h);
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-1e6, 1e6);
    std::vector<double> xyz;
    for (int i = 0; i < 30000; ++i) xyz.push_back(u(rng));
    for (double v : {2.5, -2.5, 0.5, -0.5, 0.49999999999999994, -0.49999999999999994, 2147483647.0, 2147483647.4, -2147483648.0,
                     -2147483648.4, 0.0, -0.0})
      for (int a = 0; a < 3; ++a) xyz.push_back(a == 2 ? v : h.offset[a] + v * h.scale[a]);
    const std::size_t n = xyz.size() / 3;
    std::vector<std::int32_t> XYZ(xyz.size());
    writer.quantize(xyz.data(), XYZ.data(), n, 0);
    for (std::size_t k = 0; k < xyz.size(); ++k) {
      const int a = static_cast<int>(k % 3);
      const double v = (xyz[k] - h.offset[a]) / h.scale[a];
      ASSERT_EQ(XYZ[k], static_cast<std::int32_t>(std::round(v))) << k << " " << xyz[k];
    }
    // The first point that does not fit is named (record first_record + its index), whichever
    // axis it is on; a NaN does not fit either.
    for (double bad : {2147483647.5, -2147483648.5, 1e12, std::nan("")}) {
      std::vector<double> b(xyz.begin(), xyz.begin() + 3 * 10);
      b[3 * 6 + 2] = bad;
      b[3 * 8 + 2] = 1e15;
      try {
        writer.quantize(b.data(), XYZ.data(), 10, 100);
        FAIL() << "no error for " << bad;
      } catch (const FileError& e) {
        EXPECT_NE(std::string(e.what()).find("record 106"), std::string::npos) << e.what();
      }
    }
  }
  fs::remove(path);
}

// The CRS of a LAS header (LAS 1.4 R15 §2.5.1–2.5.3), from hand-built records: a GeoKeyDirectory
// of four keys (UTM zone 13 N in metres, with a citation in GeoAsciiParams and a double in
// GeoDoubleParams), a WKT record, and malformed directories refused naming the record.
TEST(Las, CrsRecordsDecodeHandBuiltGeoKeysAndWkt) {
  io::LasHeader h;
  EXPECT_TRUE(io::lasCrs(h, "none.las").empty());
  EXPECT_EQ(io::lasCrs(h, "none.las").summary(), "none declared");
  // Header {1, 1, 0, 4 keys}, then {id, location, count, value} per key.
  const std::uint16_t keys[] = {1, 1, 0, 4, 1024, 0, 1, 1, 3072, 0, 1, 32613, 3073, 34737, 10, 0, 4099, 34736, 1, 0};
  std::vector<std::uint8_t> dir(sizeof keys);
  std::memcpy(dir.data(), keys, sizeof keys);
  const std::string ascii = "UTM 13 N |";
  const double metre = 1.0;
  std::vector<std::uint8_t> dbl(8);
  std::memcpy(dbl.data(), &metre, 8);
  h.vlrs.push_back({"LASF_Projection", 34735, "GeoKeyDirectoryTag", dir});
  h.vlrs.push_back({"LASF_Projection", 34737, "GeoAsciiParamsTag", std::vector<std::uint8_t>(ascii.begin(), ascii.end())});
  h.vlrs.push_back({"LASF_Projection", 34736, "GeoDoubleParamsTag", dbl});
  const io::LasCrs crs = io::lasCrs(h, "keys.las");
  ASSERT_EQ(crs.geo_keys.size(), 4u);
  EXPECT_EQ(crs.geo_keys[1].name(), "ProjectedCSTypeGeoKey");
  EXPECT_EQ(crs.geo_keys[1].value, 32613);
  EXPECT_EQ(crs.geo_keys[2].text, "UTM 13 N ");
  ASSERT_EQ(crs.geo_keys[3].numbers.size(), 1u);
  EXPECT_EQ(crs.geo_keys[3].numbers[0], 1.0);
  EXPECT_EQ(crs.summary(), "EPSG:32613 (GeoTIFF ProjectedCSTypeGeoKey)");
  // Four keys announced, three stored; a text beyond GeoAsciiParams.
  h.vlrs[0].data.resize(8 + 3 * 8);
  try {
    io::lasCrs(h, "keys.las");
    FAIL() << "no exception";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("keys.las:GeoKeyDirectory VLR (LASF_Projection/34735): announces 4 keys"), std::string::npos)
        << e.what();
  }
  h.vlrs[0].data = dir;
  h.vlrs[1].data.resize(5);
  EXPECT_THROW(io::lasCrs(h, "keys.las"), FileError);
  // The WKT record takes precedence; its name and outermost EPSG authority are shown (a
  // hand-written WKT 1 whose datum has an authority of its own, deeper).
  const std::string wkt =
      R"(PROJCS["WGS 84 / UTM zone 13N",GEOGCS["WGS 84",DATUM["WGS_1984",AUTHORITY["EPSG","6326"]],AUTHORITY["EPSG","4326"]],)"
      R"(PROJECTION["Transverse_Mercator"],UNIT["metre",1],AUTHORITY["EPSG","32613"]])";
  std::vector<std::uint8_t> w(wkt.begin(), wkt.end());
  w.push_back(0);
  h.vlrs.push_back({"LASF_Projection", 2112, "OGC WKT", w});
  h.vlrs[1].data.assign(ascii.begin(), ascii.end());
  EXPECT_EQ(io::lasCrs(h, "wkt.las").summary(), "EPSG:32613 'WGS 84 / UTM zone 13N' (WKT)");
  // PROJ's WKT for an EPSG code reads back as that code.
  io::LasHeader p;
  p.vlrs.push_back(io::wktVlr("EPSG:32611"));
  EXPECT_EQ(io::lasCrs(p, "proj.las").summary(), "EPSG:32611 'WGS 84 / UTM zone 11N' (WKT)");
  EXPECT_THROW(io::wktVlr("EPSG:999999"), InvalidInput);
}

// A pose or laser field whose extra-bytes scale is 0 (every value would be its offset) is
// refused naming the file and the attribute.
TEST(Las, ExtraBytesFieldOfScaleZeroIsRefused) {
  io::LasHeader h;
  h.point_format = 6;
  h.point_record_length = static_cast<std::uint16_t>(io::LasHeader::standardRecordLength(6) + 2);
  std::vector<std::uint8_t> d(192, 0);
  d[2] = 3;  // unsigned short
  d[3] = 8;  // scale valid
  std::memcpy(&d[4], "ring", 4);
  const double half = 0.5, zero = 0.0;
  std::memcpy(&d[112], &half, 8);
  h.vlrs.push_back({"LASF_Spec", 4, "extra bytes", d});
  EXPECT_NO_THROW(io::PointFieldReader(h, "zero.las", "ring"));
  std::memcpy(&h.vlrs[0].data[112], &zero, 8);
  try {
    io::PointFieldReader r(h, "zero.las", "ring");
    FAIL() << "no exception";
  } catch (const FileError& e) {
    EXPECT_NE(std::string(e.what()).find("zero.las:Extra Bytes VLR: attribute 'ring' has a scale of 0"), std::string::npos) << e.what();
  }
}
