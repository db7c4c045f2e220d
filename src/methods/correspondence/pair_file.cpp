// Correspondence pair files (`mountcal match --out`, README "Correspondence pair files"):
// PairCandidates, the matching options and the mounting used, little-endian, doubles as their
// IEEE-754 bits (a solve from the files equals one from the strips to the last bit).
//
//   offset  type          field
//   0       char[8]       "MCPAIRS2"
//   8       u32           flags: bit 0 — the pair's hulls overlap; bit 1 — attitudes stored
//                         (per-point poses; otherwise R_mb is the trajectory's at the time)
//           str, str      strip ids A, B (u32 byte count 1 to 4096, then UTF-8 bytes)
//           f64 × 3       radius r, spacing of A, spacing of B [m]
//           u64, u32      points of A and B in the overlap, sparse samples
//           f64 × 4, i32 × 2  options: apriori_misalignment_m, radius_m, sample_spacing_m,
//                         voxel_size_m; min_neighbours, max_neighbours
//           f64 × 6       mounting used (a_x, a_y, a_z [m], roll, pitch, heading [rad])
//           u64 n_s, then n_s samples of A: a point, f64 × 3 A's normal, f64 A's spread
//           u64 n_b, then n_b points of B
//           char[8]       "MCPAIREN"
//   a point: u64 index in its strip, f64 time [s], f64 × 3 x0 [m], f64 × 3 r_s [m], and with
//            bit 1 f64 × 9 R_mb (row-major)
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>

#include "mountcal/core/error.hpp"
#include "mountcal/io/atomic_file.hpp"
#include "mountcal/methods/correspondence/correspondences.hpp"

namespace mountcal {

namespace {

constexpr char kMagic[9] = "MCPAIRS2";
constexpr char kEnd[9] = "MCPAIREN";

class Out {
 public:
  void bytes(const void* p, std::size_t n) { s_.append(static_cast<const char*>(p), n); }
  void u32(std::uint32_t v) {
    for (int k = 0; k < 4; ++k) s_.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  }
  void u64(std::uint64_t v) {
    for (int k = 0; k < 8; ++k) s_.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  }
  void i32(std::int32_t v) { u32(static_cast<std::uint32_t>(v)); }
  void f64(double v) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    u64(b);
  }
  void str(const std::string& v) {
    u32(static_cast<std::uint32_t>(v.size()));
    bytes(v.data(), v.size());
  }
  std::string& data() { return s_; }

 private:
  std::string s_;
};

class In {
 public:
  In(const std::string& name, const std::uint8_t* p, std::size_t n) : name_(name), p_(p), n_(n) {}
  [[noreturn]] void fail(const std::string& what) const { throw FileError(name_, "byte " + std::to_string(at_), what); }
  void need(std::size_t k, const char* what) const {
    if (k > n_ - at_) fail(std::string("the file ends inside ") + what + " (a truncated pair file: rerun mountcal match)");
  }
  std::uint64_t uint(int bytes, const char* what) {
    need(static_cast<std::size_t>(bytes), what);
    std::uint64_t v = 0;
    for (int k = 0; k < bytes; ++k) v |= static_cast<std::uint64_t>(p_[at_ + static_cast<std::size_t>(k)]) << (8 * k);
    at_ += static_cast<std::size_t>(bytes);
    return v;
  }
  std::uint32_t u32(const char* what) { return static_cast<std::uint32_t>(uint(4, what)); }
  std::uint64_t u64(const char* what) { return uint(8, what); }
  std::int32_t i32(const char* what) { return static_cast<std::int32_t>(u32(what)); }
  double f64(const char* what, bool finite = true) {
    const std::size_t here = at_;
    const std::uint64_t b = u64(what);
    double v;
    std::memcpy(&v, &b, 8);
    if (finite && !std::isfinite(v)) {
      at_ = here;
      fail(std::string(what) + " is not a finite number");
    }
    return v;
  }
  std::string str(const char* what) {
    const std::uint32_t len = u32(what);
    if (len == 0 || len > 4096) fail(std::string(what) + ": a strip id of " + std::to_string(len) + " bytes (1 to 4096)");
    need(len, what);
    std::string v(reinterpret_cast<const char*>(p_ + at_), len);
    at_ += len;
    return v;
  }
  void magic(const char* m, const char* what) {
    need(8, what);
    if (std::memcmp(p_ + at_, m, 8) != 0) fail(std::string("not ") + what);
    at_ += 8;
  }
  /// A count of records of `each` bytes that must fit in the rest of the file.
  std::size_t count(std::uint64_t n, std::size_t each, const char* what) {
    if (n > (n_ - at_) / each)
      fail(std::string(what) + ": " + std::to_string(n) +
           " records do not fit in the rest of the file (a truncated or corrupt pair file: rerun mountcal match)");
    return static_cast<std::size_t>(n);
  }
  std::size_t at() const { return at_; }
  bool done() const { return at_ == n_; }

 private:
  std::string name_;
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t at_ = 0;
};

void writePoint(Out* o, const PairPoint& q, bool attitude) {
  o->u64(q.index);
  o->f64(q.time_s);
  for (int c = 0; c < 3; ++c) o->f64(q.x0_m[c]);
  for (int c = 0; c < 3; ++c) o->f64(q.r_s_m[c]);
  if (attitude)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) o->f64(q.R_mb(r, c));
}

std::size_t pointBytes(bool attitude) { return attitude ? 8 * 17 : 8 * 8; }

PairPoint readPoint(In* in, bool attitude, const char* what) {
  PairPoint q;
  q.index = in->u64(what);
  q.time_s = in->f64("a point's time");
  for (int c = 0; c < 3; ++c) q.x0_m[c] = in->f64("a point position");
  for (int c = 0; c < 3; ++c) q.r_s_m[c] = in->f64("a laser vector");
  if (attitude) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) q.R_mb(r, c) = in->f64("an attitude matrix element");
    if (!((q.R_mb.transpose() * q.R_mb - Mat3::Identity()).cwiseAbs().maxCoeff() < 1e-6))
      in->fail(std::string(what) + ": an attitude matrix that is not a rotation");
  }
  return q;
}

}  // namespace

bool sameMatchingOptions(const CorrespondenceOptions& x, const CorrespondenceOptions& y) {
  return x.apriori_misalignment_m == y.apriori_misalignment_m && x.radius_m == y.radius_m && x.sample_spacing_m == y.sample_spacing_m &&
         x.voxel_size_m == y.voxel_size_m && x.min_neighbours == y.min_neighbours && x.max_neighbours == y.max_neighbours;
}

void writePairCandidates(const std::string& path, const PairCandidates& p, const CorrespondenceOptions& options,
                         const std::array<double, 6>& mounting_used) {
  Out out;
  out.bytes(kMagic, 8);
  out.u32((p.overlap ? 1u : 0u) | (p.attitudes_stored ? 2u : 0u));
  out.str(p.strip_a);
  out.str(p.strip_b);
  out.f64(p.radius_m);
  out.f64(p.spacing_a_m);
  out.f64(p.spacing_b_m);
  out.u64(p.overlap_points);
  out.u32(static_cast<std::uint32_t>(p.sparse_samples));
  out.f64(options.apriori_misalignment_m);
  out.f64(options.radius_m);
  out.f64(options.sample_spacing_m);
  out.f64(options.voxel_size_m);
  out.i32(options.min_neighbours);
  out.i32(options.max_neighbours);
  for (double v : mounting_used) out.f64(v);
  out.u64(p.samples_a.size());
  for (std::size_t k = 0; k < p.samples_a.size(); ++k) {
    writePoint(&out, p.samples_a[k], p.attitudes_stored);
    for (int c = 0; c < 3; ++c) out.f64(p.normal_a[k][c]);
    out.f64(p.spread_a[k]);
  }
  out.u64(p.points_b.size());
  for (const PairPoint& q : p.points_b) writePoint(&out, q, p.attitudes_stored);
  out.bytes(kEnd, 8);
  io::writeFileAtomically(path, out.data());
}

PairCandidates parsePairCandidates(const std::string& name, const std::uint8_t* data, std::size_t size, CorrespondenceOptions* options,
                                   std::array<double, 6>* mounting_used) {
  In in(name, data, size);
  in.magic(kMagic, "a mountcal pair file of this version (it starts with MCPAIRS2)");
  PairCandidates p;
  const std::uint32_t flags = in.u32("the flags");
  if (flags > 3) in.fail("unknown flags " + std::to_string(flags));
  p.overlap = flags & 1;
  p.attitudes_stored = (flags & 2) != 0;
  p.strip_a = in.str("strip A's id");
  p.strip_b = in.str("strip B's id");
  if (p.strip_a == p.strip_b) in.fail("strips A and B are both '" + p.strip_a + "'");
  p.radius_m = in.f64("the radius");
  p.spacing_a_m = in.f64("A's spacing");
  p.spacing_b_m = in.f64("B's spacing");
  if (!(p.radius_m > 0) || p.spacing_a_m < 0 || p.spacing_b_m < 0) in.fail("the radius must be positive and the spacings non-negative");
  p.overlap_points = in.u64("the overlap point count");
  const std::uint32_t sparse = in.u32("the sparse sample count");
  if (sparse > static_cast<std::uint32_t>(std::numeric_limits<int>::max())) in.fail("a sparse sample count of " + std::to_string(sparse));
  p.sparse_samples = static_cast<int>(sparse);
  CorrespondenceOptions opts;
  opts.apriori_misalignment_m = in.f64("the options");
  opts.radius_m = in.f64("the options");
  opts.sample_spacing_m = in.f64("the options");
  opts.voxel_size_m = in.f64("the options");
  opts.min_neighbours = in.i32("the options");
  opts.max_neighbours = in.i32("the options");
  std::string why;
  if (!opts.IsValid(&why)) in.fail("matching options: " + why);
  std::array<double, 6> m{};
  for (double& v : m) v = in.f64("the mounting used");
  const bool att = p.attitudes_stored;
  p.samples_a.resize(in.count(in.u64("the sample count"), pointBytes(att) + 32, "the samples"));
  p.normal_a.resize(p.samples_a.size());
  p.spread_a.resize(p.samples_a.size());
  for (std::size_t k = 0; k < p.samples_a.size(); ++k) {
    p.samples_a[k] = readPoint(&in, att, "a sample of A");
    for (int c = 0; c < 3; ++c) p.normal_a[k][c] = in.f64("A's normal");
    if (std::abs(p.normal_a[k].norm() - 1.0) > 1e-6) in.fail("A's normal at sample " + std::to_string(k) + " is not a unit vector");
    p.spread_a[k] = in.f64("A's spread");
  }
  p.points_b.resize(in.count(in.u64("B's point count"), pointBytes(att), "B's points"));
  for (PairPoint& q : p.points_b) q = readPoint(&in, att, "a point of B");
  if (p.samples_a.empty() != p.points_b.empty()) in.fail("samples without points of B, or points of B without samples");
  in.magic(kEnd, "the end mark MCPAIREN (a truncated or corrupt pair file: rerun mountcal match)");
  if (!in.done()) in.fail("bytes after the end mark");
  if (!p.overlap && (!p.samples_a.empty() || p.sparse_samples)) in.fail("samples in a pair without overlap");
  if (options) *options = opts;
  if (mounting_used) *mounting_used = m;
  return p;
}

PairCandidates readPairCandidates(const std::string& path, CorrespondenceOptions* options, std::array<double, 6>* mounting_used) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw FileError(path, "", "is not a regular file (a pair file of mountcal match)");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw FileError(path, "", "cannot open the pair file");
  f.seekg(0, std::ios::end);
  const std::streamoff size = f.tellg();
  if (size < 0) throw FileError(path, "", "cannot determine the file size (a pair file must be a regular file)");
  if (size > (std::streamoff{1} << 36)) throw FileError(path, "", "a pair file of " + std::to_string(size) + " bytes (over 64 GiB)");
  f.seekg(0, std::ios::beg);
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  if (size > 0 && !f.read(reinterpret_cast<char*>(bytes.data()), size)) throw FileError(path, "", "cannot read the pair file");
  return parsePairCandidates(path, bytes.data(), bytes.size(), options, mounting_used);
}

}  // namespace mountcal
