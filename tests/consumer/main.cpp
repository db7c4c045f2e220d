// Georeferences one pulse through the installed library and checks the answer by hand.
#include <cmath>
#include <cstdio>
#include <mountcal/mountcal.hpp>

int main() {
  using namespace mountcal;
  std::vector<TrajectorySample> samples(2);
  samples[1].time_s = 1.0;
  samples[0].p_m = samples[1].p_m = Vec3(100, 200, 1000);
  GeoreferenceModel model(Trajectory(samples), MountingParameters{});
  // level, heading 0: body z (down) → mapping −z; 1000 m range at nadir lands at z = 0.
  const Vec3 x_m = model.forward(0.5, LineScannerModel{}.vector(0.0, 1000.0));
  const bool ok = (x_m - Vec3(100, 200, 0)).norm() < 1e-9;
  std::printf("mountcal %s consumer: x_m = (%.3f, %.3f, %.3f) %s\n", MOUNTCAL_VERSION_STRING, x_m.x(), x_m.y(), x_m.z(),
              ok ? "OK" : "WRONG");
  return ok ? 0 : 1;
}
