#include "mountcal/evaluation.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <map>

#include "mountcal/error.hpp"
#include "mountcal/detail/vtp_strip.hpp"
#include "mountcal/georeference_model.hpp"

namespace mountcal {

CheckPointReport evaluateCheckPoints(const CalibrationData& data, const MountingParameters& mounting,
                                     const VtpOptions& options) {
  CheckPointReport report;
  std::map<std::string, const StripData*> strips;
  for (const StripData& s : data.strips) strips[s.id] = &s;
  std::map<std::string, VtpStrip> built;
  std::map<std::string, std::vector<VirtualTiePoint>> by_tie;
  for (const TieObservation& t : data.ties) {
    auto it = strips.find(t.strip_id);
    if (it == strips.end()) throw InvalidInput("check point '" + t.tie_id + "' names strip '" + t.strip_id + "', which is not in the job");
    auto b = built.find(t.strip_id);
    if (b == built.end()) b = built.emplace(t.strip_id, VtpStrip(*it->second, data.trajectory, data.mounting_used)).first;
    VirtualTiePoint v;
    std::string reason;
    if (b->second.build(t, options, &v, &reason)) by_tie[t.tie_id].push_back(std::move(v));
    else report.rejected.push_back({t.tie_id, t.strip_id, reason});
  }
  const auto m6 = mounting.toArray();
  Vec3 ss = Vec3::Zero();
  for (const auto& [id, vtps] : by_tie) {
    if (vtps.size() < 2) {
      for (const auto& v : vtps) report.rejected.push_back({id, v.stripId(), "the check point has a usable observation on only one strip"});
      continue;
    }
    std::vector<Vec3> P;
    Vec3 mean = Vec3::Zero();
    for (const auto& v : vtps) {
      P.push_back(v.position(m6.data()));  // Rule 2
      mean += P.back();
    }
    mean /= static_cast<double>(P.size());  // seed eq. (7)
    for (std::size_t i = 0; i < P.size(); ++i) {
      report.residuals.push_back({id, vtps[i].stripId(), P[i] - mean});  // seed eq. (8)
      ss += (P[i] - mean).cwiseAbs2();
    }
  }
  if (!report.residuals.empty()) report.rms_m = (ss / static_cast<double>(report.residuals.size())).cwiseSqrt();
  return report;
}

std::vector<CheckPlaneResult> evaluateCheckPlanes(const CalibrationData& data, const std::vector<PlaneRegion>& regions,
                                                  const MountingParameters& mounting) {
  std::vector<CheckPlaneResult> out;
  std::vector<std::vector<Vec3>> pts(regions.size());
  const Mat3 R_bs = mounting.R_bs();
  for (const StripData& s : data.strips) {
    if (s.x_m.size() != s.time_s.size()) throw InvalidInput("strip '" + s.id + "': x_m is needed to select check-plane points");
    std::size_t cursor = 0;
    for (std::size_t i = 0; i < s.time_s.size(); ++i) {
      const Vec3& x0 = s.x_m[i];
      for (std::size_t r = 0; r < regions.size(); ++r) {
        const PlaneRegion& g = regions[r];
        if (x0.x() < g.xmin || x0.x() > g.xmax || x0.y() < g.ymin || x0.y() > g.ymax) continue;
        const Pose pose = data.trajectory->pose(s.time_s[i], &cursor);
        pts[r].push_back(georeference(pose, R_bs, mounting.a_b, s.r_s[i]));
      }
    }
  }
  for (std::size_t r = 0; r < regions.size(); ++r) {
    CheckPlaneResult res;
    res.plane_id = regions[r].id;
    res.points = static_cast<int>(pts[r].size());
    if (pts[r].size() < 4) {
      res.rms_m = std::nan("");
      out.push_back(res);
      continue;
    }
    Vec3 c = Vec3::Zero();
    for (const Vec3& p : pts[r]) c += p;
    c /= static_cast<double>(pts[r].size());
    Mat3 C = Mat3::Zero();
    for (const Vec3& p : pts[r]) C += (p - c) * (p - c).transpose();
    const Eigen::SelfAdjointEigenSolver<Mat3> eig(C);
    // Smallest eigenvalue = Σ d_i² about the least-squares plane; seed eq. (13).
    res.rms_m = std::sqrt(std::max(eig.eigenvalues()(0), 0.0) / static_cast<double>(pts[r].size() - 3));
    out.push_back(res);
  }
  return out;
}

}  // namespace mountcal
