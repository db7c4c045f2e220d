#include "mountcal/job/block.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

#include "mountcal/core/error.hpp"
#include "mountcal/io/las.hpp"

namespace mountcal {

namespace fs = std::filesystem;

namespace {

/// Pair jobs run method "correspondences" in its sparse (block) form.
void requireBlockMethod(const Job& job, bool only) {
  const auto& m = job.options.methods;
  const bool has = std::find(m.begin(), m.end(), CorrespondenceOptions::kMethod) != m.end();
  if (!has || (only && m.size() != 1))
    throw FileError(job.path, "field 'method'",
                    only ? "a solve from pair files runs method \"correspondences\" alone" : "pair jobs need method \"correspondences\"");
  if (job.options.method<CorrespondenceOptions>().dense)
    throw FileError(
        job.path, "field 'correspondences.dense'",
        "dense matching rebuilds its k-d trees at every round and is not split into pair jobs; run mountcal calibrate on the whole job");
}

int stripIndex(const Job& job, const std::string& id) {
  for (std::size_t s = 0; s < job.strips.size(); ++s)
    if (job.strips[s].id == id) return static_cast<int>(s);
  throw FileError(job.path, "field 'strips'", "no strip '" + id + "'");
}

}  // namespace

std::vector<std::pair<std::string, std::string>> jobStripPairs(const Job& job) {
  requireBlockMethod(job, false);
  struct Box {
    double x0 = -1e300, y0 = -1e300, x1 = 1e300, y1 = 1e300, spacing = 0;
    bool known = false;
  };
  std::vector<Box> box(job.strips.size());
  for (std::size_t s = 0; s < job.strips.size(); ++s) {
    const JobStrip& js = job.strips[s];
    if (js.format != "las") continue;  // raw CSV strips have no header: paired with every strip
    io::LasReader r(js.path);
    const io::LasHeader& h = r.header();
    Box& b = box[s];
    b.x0 = h.min[0], b.y0 = h.min[1], b.x1 = h.max[0], b.y1 = h.max[1];
    // Mean spacing over the box (the strip covers at most its box: never below the true one).
    b.spacing = std::sqrt(std::max((b.x1 - b.x0) * (b.y1 - b.y0), 1.0) / static_cast<double>(std::max<std::uint64_t>(h.point_count, 1)));
    b.known = true;
  }
  const CorrespondenceOptions& opts = job.options.method<CorrespondenceOptions>();
  std::vector<std::pair<std::string, std::string>> out;
  for (std::size_t a = 0; a < box.size(); ++a) {
    for (std::size_t b = a + 1; b < box.size(); ++b) {
      const Box &A = box[a], &B = box[b];
      bool meet = true;
      if (A.known && B.known) {
        // The search pairs strips within two voxels (Matcher: boxes grown by 2 voxels); here 4,
        // with the spacing doubled, for a plan box in the CRS against points in the local frame.
        const double r = opts.radius_m > 0 ? opts.radius_m : std::max(0.25, 2.5 * 2.0 * std::max(A.spacing, B.spacing));
        const double voxel = opts.voxel_size_m > 0 ? opts.voxel_size_m : std::max(2.0, 4 * r);
        const double margin = std::max(25.0, 4 * voxel);
        meet = !(A.x0 > B.x1 + margin || B.x0 > A.x1 + margin || A.y0 > B.y1 + margin || B.y0 > A.y1 + margin);
      }
      if (meet) out.emplace_back(job.strips[a].id, job.strips[b].id);
    }
  }
  return out;
}

Job jobWithStrips(const Job& job, const std::vector<std::string>& ids) {
  Job sub = job;
  sub.strips.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    for (std::size_t l = 0; l < k; ++l)
      if (ids[l] == ids[k])
        throw FileError(job.path, "field 'strips'",
                        ids.size() == 2 ? "a pair of one strip ('" + ids[k] + "')" : "strip '" + ids[k] + "' named twice");
    sub.strips.push_back(job.strips[static_cast<std::size_t>(stripIndex(job, ids[k]))]);
  }
  sub.ties_path.clear();
  sub.gcps_path.clear();
  sub.planes_path.clear();
  sub.targets_path.clear();
  sub.check_points_path.clear();
  sub.check_planes_path.clear();
  return sub;
}

PairCandidates jobPairCandidates(const Job& job, const std::string& a, const std::string& b) {
  requireBlockMethod(job, false);
  // The two strips, in job order, and the trajectory: nothing else is read.
  const bool swapped = stripIndex(job, a) > stripIndex(job, b);
  const LoadedJob loaded = loadJob(jobWithStrips(job, swapped ? std::vector<std::string>{b, a} : std::vector<std::string>{a, b}));
  return findPairCandidates(loaded.data, 0, 1, job.options.method<CorrespondenceOptions>());
}

std::vector<std::string> pairFilesIn(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw FileError(dir, "", "is not a folder of pair files (mountcal match --out)");
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".mcpair") files.push_back(e.path().string());
  if (ec) throw FileError(dir, "", "cannot list the folder: " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

LoadedJob loadJobFromPairFiles(const Job& job, const std::string& dir) {
  requireBlockMethod(job, true);
  if (!job.gcps_path.empty())
    throw FileError(job.path, "field 'gcps'",
                    "ground control is observed in the strips' points, which a solve from pair files does not read; run mountcal calibrate "
                    "on the whole job");
  const std::vector<std::string> files = pairFilesIn(dir);
  LoadedJob out = loadJobTrajectory(job);
  auto pairs = std::make_shared<std::vector<PairCandidates>>();
  std::map<std::pair<std::string, std::string>, std::string> seen;
  const std::array<double, 6> used = job.mounting_used.toArray();
  for (const std::string& f : files) {
    CorrespondenceOptions opts;
    std::array<double, 6> m{};
    PairCandidates p = readPairCandidates(f, &opts, &m);
    for (const std::string& id : {p.strip_a, p.strip_b})
      if (std::none_of(job.strips.begin(), job.strips.end(), [&](const JobStrip& js) { return js.id == id; }))
        throw FileError(f, "", "names strip '" + id + "', which " + job.path + " does not list; rerun mountcal match with this job");
    if (p.strip_a == p.strip_b) throw FileError(f, "", "pairs strip '" + p.strip_a + "' with itself; rerun mountcal match");
    if (!sameMatchingOptions(opts, job.options.method<CorrespondenceOptions>()))
      throw FileError(f, "", "was matched with other correspondence options than " + job.path + "; rerun mountcal match");
    if (m != used) throw FileError(f, "", "was matched at another mounting_used than " + job.path + "'s; rerun mountcal match");
    if (!p.attitudes_stored) {
      if (!out.data.trajectory)
        throw FileError(f, "", "holds no attitudes, and the job has no trajectory to take them from; rerun mountcal match");
      p.attitudesFrom(*out.data.trajectory);
    }
    auto [it, fresh] = seen.emplace(std::make_pair(p.strip_a, p.strip_b), f);
    if (!fresh) throw FileError(f, "", "holds strips '" + p.strip_a + "' and '" + p.strip_b + "' as " + it->second + " does");
    pairs->push_back(std::move(p));
  }
  for (const auto& [a, b] : jobStripPairs(job)) {
    if (!seen.count({a, b}))
      throw FileError(dir, "",
                      "no pair file for strips '" + a + "' and '" + b + "' (mountcal match " + job.path + " --pair " + a + " " + b + ")");
  }
  for (const JobStrip& js : job.strips) {
    StripData s;
    s.id = js.id;
    out.data.strips.push_back(std::move(s));
  }
  out.data.correspondence_candidates = pairs;
  return out;
}

}  // namespace mountcal
