#pragma once
// Internal: the module of method "correspondences" (registered in src/methods/registry.cpp).

#include "mountcal/methods/correspondence/correspondences.hpp"

namespace mountcal {

class CorrespondencesMethod final : public Method {
 public:
  std::string name() const override { return CorrespondenceOptions::kMethod; }
  std::string description() const override;
  std::vector<std::string> legacyOptionKeys() const override { return {"correspondence"}; }
  std::any defaultOptions() const override { return CorrespondenceOptions{}; }
  const std::vector<OptionSpec>& options() const override;
  bool validate(const std::any& options, std::string* error) const override;
  bool estimatesLaserIntrinsics(const std::any& options) const override {
    const auto& o = std::any_cast<const CorrespondenceOptions&>(options);
    return o.dense && o.estimatesLaserIntrinsics();
  }
  void adoptNoise(const NoiseHint& noise, std::any* options) const override;
  std::unique_ptr<MethodRun> run(const MethodContext& context) const override;
};

}  // namespace mountcal
