// A toy method that lives in the test tree: a tape-measured vertical lever arm as one
// observation of the mounting. It proves that a method is one module — this folder and the one
// registration at the bottom, no other file — and is listed, parsed from a job, solved with the
// other methods, and written to the summary, the result file and the report by the same code
// that serves the built-in methods.
#include <ceres/sized_cost_function.h>

#include <cstdio>
#include <memory>
#include <string>

#include "mountcal/methods/method.hpp"

namespace mountcal::toy {

/// Options of method "toy" (job object "toy").
struct ToyOptions {
  static constexpr const char* kMethod = "toy";
  double lever_arm_z_m = 0.0;  ///< the measured vertical lever arm [m]
  double sigma_m = 0.01;       ///< its standard deviation [m]
  /// A matching that never settles (for the re-solve check): the measurement is taken as the
  /// vertical lever arm the run first sees plus this, so every solve started from the previous
  /// result moves it again [m]. 0: a fixed measurement.
  double drift_m = 0.0;
};

/// r = (a_z − measured) / σ: linear, so its Jacobian is exact.
class MeasuredLeverZ final : public ceres::SizedCostFunction<1, 6> {
 public:
  MeasuredLeverZ(double value_m, double sigma_m) : value_m_(value_m), sigma_m_(sigma_m) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    r[0] = (p[0][2] - value_m_) / sigma_m_;
    if (J && J[0]) {
      for (int k = 0; k < 6; ++k) J[0][k] = 0.0;
      J[0][2] = 1.0 / sigma_m_;
    }
    return true;
  }

 private:
  double value_m_, sigma_m_;
};

struct ToySection final : MethodSection {
  double measured_m = 0, sigma_m = 0, estimated_m = 0;
  std::string method() const override { return ToyOptions::kMethod; }
  std::string brief() const override { return "1 measured lever arm; "; }
  std::string text(const AdjustmentSummary&) const override {
    char b[160];
    std::snprintf(b, sizeof b, "\nToy: measured lever arm z %.4f m (sigma %.4f m), estimated %.4f m\n", measured_m, sigma_m, estimated_m);
    return b;
  }
  std::string resultJson(const AdjustmentSummary&) const override {
    char b[160];
    std::snprintf(b, sizeof b, "{\"toy\": {\"measured_z_m\": %.17g, \"sigma_m\": %.17g, \"estimated_z_m\": %.17g}}", measured_m, sigma_m,
                  estimated_m);
    return b;
  }
  std::string html(const AdjustmentSummary&) const override {
    char b[200];
    std::snprintf(b, sizeof b, "<h2>Toy: measured lever arm</h2><p>measured %.4f m, estimated %.4f m</p>", measured_m, estimated_m);
    return b;
  }
};

class ToySource final : public ObservationSource {
 public:
  ToySource(double value_m, double sigma_m, double drift_m) : value_m_(value_m), sigma_m_(sigma_m), drift_m_(drift_m) {}
  std::string kind() const override { return "toy"; }
  bool rematches() const override { return drift_m_ != 0.0; }
  void addBlocks(const std::array<double, 6>& mounting, AdjustmentProblem* problem) override {
    if (drift_m_ != 0.0 && !first_seen_) {
      value_m_ = mounting[2] + drift_m_;
      first_seen_ = true;
    }
    problem->addResidualBlock(new MeasuredLeverZ(value_m_, sigma_m_), 0.0, {problem->mounting()});
  }
  void finish(const std::array<double, 6>&, const std::array<double, 6>& mounting, const AdjustmentProblem&,
              const AnalysisOptions&) override {
    estimated_m = mounting[2];
  }
  double estimated_m = 0;

 private:
  double value_m_, sigma_m_, drift_m_;
  bool first_seen_ = false;
};

class ToyRun final : public MethodRun {
 public:
  explicit ToyRun(const ToyOptions& o) : options_(o), source_(o.lever_arm_z_m, o.sigma_m, o.drift_m) {}
  std::vector<ObservationSource*> sources() override { return {&source_}; }
  std::shared_ptr<const MethodSection> section() const override {
    auto s = std::make_shared<ToySection>();
    s->measured_m = options_.lever_arm_z_m;
    s->sigma_m = options_.sigma_m;
    s->estimated_m = source_.estimated_m;
    return s;
  }

 private:
  ToyOptions options_;
  ToySource source_;
};

class ToyMethod final : public Method {
 public:
  std::string name() const override { return ToyOptions::kMethod; }
  std::string description() const override { return "a tape-measured vertical lever arm (a toy method from the test tree)"; }
  std::any defaultOptions() const override { return ToyOptions{}; }
  const std::vector<OptionSpec>& options() const override {
    using T = ToyOptions;
    static const std::vector<OptionSpec> specs =
        OptionTable<T>()
            .number(
                "lever_arm_z_m", [](T& o) -> double& { return o.lever_arm_z_m; }, "m", -100, 100, "the measured vertical lever arm")
            .number(
                "sigma_m", [](T& o) -> double& { return o.sigma_m; }, "m", 1e-6, 10, "its standard deviation")
            .number(
                "drift_m", [](T& o) -> double& { return o.drift_m; }, "m", -10, 10,
                "a matching that never settles: each run measures what it first sees plus this")
            .specs();
    return specs;
  }
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override {
    return std::make_unique<ToyRun>(std::any_cast<const ToyOptions&>(context.options));
  }
};

// The one registration.
const MethodRegistration kRegistration(std::make_shared<ToyMethod>());

}  // namespace mountcal::toy
