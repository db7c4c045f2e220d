// Georeferences one pulse through the installed mountcal::core alone (no Ceres, FLANN, OpenMesh
// or PROJ in this program's link), with the answer checked by hand: a 1000 m nadir range from
// 1000 m of height, level flight, lands on the ground below the IMU plus the lever arm.
#include <cstdio>
#include <mountcal/core/georeference_model.hpp>

int main() {
  using namespace mountcal;
  std::vector<TrajectorySample> samples(2);
  samples[1].time_s = 1.0;
  samples[0].p_m = samples[1].p_m = Vec3(100, 200, 1000);
  MountingParameters mounting;
  mounting.a_b = Vec3(0.5, 0.25, 0.0);  // body forward, right → (local ENU, heading 0) north, east
  GeoreferenceModel model(Trajectory(samples), mounting);
  const Vec3 x_m = model.forward(0.5, LineScannerModel{}.vector(0.0, 1000.0));
  const bool ok = (x_m - Vec3(100.25, 200.5, 0)).norm() < 1e-9;
  std::printf("mountcal::core consumer: x_m = (%.3f, %.3f, %.3f) %s\n", x_m.x(), x_m.y(), x_m.z(), ok ? "OK" : "WRONG");
  return ok ? 0 : 1;
}
