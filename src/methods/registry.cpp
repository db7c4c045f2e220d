// The method registry (methods/method.hpp). Built-in methods are registered here, one line
// each, in the order their observations join the adjustment.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "control/control_method.hpp"
#include "correspondence/correspondences_method.hpp"
#include "features/features_method.hpp"
#include "mountcal/core/error.hpp"
#include "planes/planes_method.hpp"
#include "vtpm/vtpm_method.hpp"

namespace mountcal {

namespace {

std::vector<std::shared_ptr<const Method>>& registry() {
  static std::vector<std::shared_ptr<const Method>> methods = [] {
    std::vector<std::shared_ptr<const Method>> m;
    m.push_back(std::make_shared<VtpmMethod>());
    m.push_back(std::make_shared<ControlMethod>());
    m.push_back(std::make_shared<PlanesMethod>());
    m.push_back(std::make_shared<CorrespondencesMethod>());
    m.push_back(std::make_shared<FeaturesMethod>());
    return m;
  }();
  return methods;
}

}  // namespace

const std::vector<std::shared_ptr<const Method>>& registeredMethods() { return registry(); }

const Method* findMethod(const std::string& name) {
  for (const auto& m : registry())
    if (m->name() == name) return m.get();
  return nullptr;
}

void registerMethod(std::shared_ptr<const Method> method) {
  if (!method) throw InvalidInput("registerMethod: null method");
  if (findMethod(method->name())) throw InvalidInput("registerMethod: a method named '" + method->name() + "' is registered already");
  registry().push_back(std::move(method));
}

std::string methodNames() {
  std::string s;
  for (const auto& m : registry())
    if (!m->implicit()) s += (s.empty() ? "\"" : ", \"") + m->name() + "\"";
  return s;
}

bool validateMethodOptions(const Method& method, const std::any& options, std::string* error) {
  for (const OptionSpec& spec : method.options()) {
    const double v = spec.get(options);
    if (!(v >= spec.min && v <= spec.max) || !std::isfinite(v)) {
      if (error) {
        std::ostringstream m;
        m << method.name() << "." << spec.key << " = " << v << " is outside [" << spec.min << ", " << spec.max << "]";
        *error = m.str();
      }
      return false;
    }
  }
  std::string why;
  if (!method.validate(options, &why)) {
    if (error) *error = method.name() + ": " + why;
    return false;
  }
  return true;
}

std::string describeMethods() {
  std::ostringstream out;
  out << "Methods of mountcal (a job names one or an array of them in \"method\"; their observations join one adjustment).\n"
         "Options go in the job's object of the method's name, e.g. \"planes\": {\"sigma_m\": 0.02}.\n";
  for (const auto& m : registry()) {
    out << "\n"
        << m->name() << (m->implicit() ? " (runs whenever its input is given; not named in \"method\")" : "") << "\n  " << m->description()
        << "\n";
    const MethodInput in = m->input();
    if (!in.job_key.empty()) out << "  input: \"" << in.job_key << "\": " << in.doc << (in.required ? "" : " (optional)") << "\n";
    const std::any defaults = m->defaultOptions();
    for (const OptionSpec& s : m->options()) {
      std::ostringstream def, range;
      if (s.type == OptionSpec::Type::kBoolean) {
        def << (s.get(defaults) != 0 ? "true" : "false");
      } else if (s.type == OptionSpec::Type::kChoice) {
        def << '"' << s.choices.at(static_cast<std::size_t>(s.get(defaults))) << '"';
        for (const std::string& c : s.choices) range << (c == s.choices.front() ? " (" : ", ") << '"' << c << '"';
        range << ")";
      } else {
        def << s.get(defaults);
        range << " [" << s.min << ", " << s.max << "]";
      }
      char line[160];
      std::snprintf(line, sizeof line, "    %-26s %-10s %-5s", s.key.c_str(), def.str().c_str(), s.unit.c_str());
      out << line << " " << s.doc << range.str() << "\n";
    }
  }
  out << "\nShared by every method: \"stochastic\": {\"strip_offset_sigma_m\": 0.02} (m; a 3-D offset per strip, 0: off), "
         "\"pulse_noise\", \"estimate\", \"solver\" (SPEC §4).\n";
  return out.str();
}

}  // namespace mountcal
