#pragma once
// Internal: the ground-control module (registered in src/methods/registry.cpp).

#include "mountcal/methods/control/control.hpp"

namespace mountcal {

class ControlMethod final : public Method {
 public:
  std::string name() const override;
  std::string description() const override;
  MethodInput input() const override;
  bool implicit() const override { return true; }
  std::any defaultOptions() const override;
  const std::vector<OptionSpec>& options() const override;
  bool validate(const std::any& options, std::string* error) const override;
  void adoptNoise(const NoiseHint& noise, std::any* options) const override;
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override;
};

}  // namespace mountcal
