#pragma once
// Internal: the module of method "planes" (registered in src/methods/registry.cpp).

#include "mountcal/methods/planes/plane_observations.hpp"

namespace mountcal {

class PlanesMethod final : public Method {
 public:
  std::string name() const override { return PlaneOptions::kMethod; }
  std::string description() const override;
  MethodInput input() const override;
  std::vector<std::string> legacyOptionKeys() const override { return {"plane"}; }
  std::any defaultOptions() const override { return PlaneOptions{}; }
  const std::vector<OptionSpec>& options() const override;
  void adoptInput(const std::string& value, std::any* options) const override;
  bool validate(const std::any& options, std::string* error) const override;
  bool estimatesLaserIntrinsics(const std::any& options) const override {
    return std::any_cast<const PlaneOptions&>(options).estimatesLaserIntrinsics();
  }
  void adoptNoise(const NoiseHint& noise, std::any* options) const override;
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override;
};

}  // namespace mountcal
