#pragma once
// Internal: the module of method "features" (registered in src/methods/registry.cpp).

#include "mountcal/methods/features/feature_observations.hpp"

namespace mountcal {

class FeaturesMethod final : public Method {
 public:
  std::string name() const override { return FeatureOptions::kMethod; }
  std::string description() const override;
  MethodInput input() const override;
  std::any defaultOptions() const override { return FeatureOptions{}; }
  const std::vector<OptionSpec>& options() const override;
  bool validate(const std::any& options, std::string* error) const override;
  bool estimatesLaserIntrinsics(const std::any& options) const override {
    return std::any_cast<const FeatureOptions&>(options).estimatesLaserIntrinsics();
  }
  void adoptNoise(const NoiseHint& noise, std::any* options) const override;
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override;
};

}  // namespace mountcal
