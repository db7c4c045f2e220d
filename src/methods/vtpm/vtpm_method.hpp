#pragma once
// Internal: the module of method "vtpm" (registered in src/methods/registry.cpp).

#include "mountcal/methods/vtpm/vtpm.hpp"

namespace mountcal {

class VtpmMethod final : public Method {
 public:
  std::string name() const override;
  std::string description() const override;
  MethodInput input() const override;
  std::any defaultOptions() const override;
  const std::vector<OptionSpec>& options() const override;
  bool validate(const std::any& options, std::string* error) const override;
  void adoptNoise(const NoiseHint& noise, std::any* options) const override;
  std::set<std::string> claimedGcps(const CalibrationData& data) const override;
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override;
};

}  // namespace mountcal
