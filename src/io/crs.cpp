#include "mountcal/io/crs.hpp"

#include <proj.h>

#include <cmath>

#include "mountcal/core/error.hpp"

namespace mountcal::io {

struct CrsTransform::Impl {
  PJ_CONTEXT* ctx = nullptr;
  PJ* pj = nullptr;
  ~Impl() {
    if (pj) proj_destroy(pj);
    if (ctx) proj_context_destroy(ctx);
  }
};

CrsTransform::CrsTransform(const std::string& crs) : impl_(std::make_unique<Impl>()) {
  impl_->ctx = proj_context_create();
  proj_log_level(impl_->ctx, PJ_LOG_NONE);
  PJ* raw = proj_create_crs_to_crs(impl_->ctx, crs.c_str(), "EPSG:4979", nullptr);
  if (!raw)
    throw InvalidInput("unknown or unsupported CRS '" + crs +
                       "' (PROJ: " + proj_context_errno_string(impl_->ctx, proj_context_errno(impl_->ctx)) + ")");
  impl_->pj = proj_normalize_for_visualization(impl_->ctx, raw);  // x = lon/easting, y = lat/northing
  proj_destroy(raw);
  if (!impl_->pj) throw InvalidInput("CRS '" + crs + "': PROJ could not normalise the axis order");
}

CrsTransform::~CrsTransform() = default;

bool CrsTransform::isGeographic(const std::string& crs) {
  PJ_CONTEXT* ctx = proj_context_create();
  proj_log_level(ctx, PJ_LOG_NONE);
  PJ* p = proj_create(ctx, crs.c_str());
  if (!p) {
    proj_context_destroy(ctx);
    throw InvalidInput("unknown or unsupported CRS '" + crs + "'");
  }
  const PJ_TYPE type = proj_get_type(p);
  proj_destroy(p);
  proj_context_destroy(ctx);
  return type == PJ_TYPE_GEOGRAPHIC_CRS || type == PJ_TYPE_GEOGRAPHIC_2D_CRS || type == PJ_TYPE_GEOGRAPHIC_3D_CRS;
}

Geodetic CrsTransform::toGeodetic(const Vec3& x) const {
  const PJ_COORD out = proj_trans(impl_->pj, PJ_FWD, proj_coord(x.x(), x.y(), x.z(), 0));
  if (!std::isfinite(out.xyz.x)) throw InvalidInput("CRS conversion failed for a point");
  return {deg2rad(out.lpzt.phi), deg2rad(out.lpzt.lam), out.lpzt.z};
}

Vec3 CrsTransform::fromGeodetic(const Geodetic& g) const {
  const PJ_COORD out = proj_trans(impl_->pj, PJ_INV, proj_coord(rad2deg(g.lon), rad2deg(g.lat), g.h, 0));
  if (!std::isfinite(out.xyz.x)) throw InvalidInput("CRS conversion failed for a point");
  return {out.xyz.x, out.xyz.y, out.xyz.z};
}

}  // namespace mountcal::io
