#pragma once
/// \file methods/method.hpp
/// A calibration method is one module, registered by name (DESIGN.md, "One adjustment, many
/// kinds of observation"). A module
///   - declares its job options once (OptionTable: key, type, unit, range, default, meaning) —
///     the job parser, Options::IsValid, `mountcal methods` and the docs read that declaration;
///   - turns the strips (+ its user input) into observation sources of the one adjustment and,
///     optionally, a starting value (MethodRun);
///   - writes its own Summary section: a clause of BriefReport, a part of FullReport, its keys
///     of the result file and its section of the HTML report (MethodSection).
/// The facade (MountingCalibrator), the result writer, the reports, the CLI and the planner
/// iterate over the registry; none of them names a method.
///
/// Adding a method: write a Method subclass and register it once, either in
/// src/methods/registry.cpp (built-in) or with a static `MethodRegistration` in the
/// program that links it (tests/methods/toy/ does so).

#include <any>
#include <array>
#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "mountcal/adjustment/mounting_adjustment.hpp"
#include "mountcal/data.hpp"

namespace mountcal {

// ---- options declared once ------------------------------------------------------------------

/// One option of a method, as the job file names it.
struct OptionSpec {
  enum class Type { kNumber, kInteger, kBoolean, kChoice };
  std::string key;  ///< job key inside the method's object, e.g. "radius_m"
  Type type = Type::kNumber;
  std::string unit;                            ///< "m", "deg", "-" …
  double min = 0, max = 0;                     ///< accepted range, inclusive (numbers and integers)
  double default_value = 0;                    ///< of a default-constructed options object
  std::string doc;                             ///< one line
  std::vector<std::string> choices;            ///< kChoice: the job's names of the values 0, 1, … (an enum's order)
  std::function<double(const std::any&)> get;  ///< value of this option in an options object
  std::function<void(std::any&, double)> set;  ///< sets it (booleans: 0 / 1)
};

/// Builds the OptionSpecs of an options struct T from accessors, so that each option is
/// declared exactly once: `table.number("radius_m", [](T& o) -> double& { return o.radius_m; },
/// "m", 0.01, 100, "search radius")`.
template <class T>
class OptionTable {
 public:
  template <class Access>
  OptionTable& number(std::string key, Access access, std::string unit, double lo, double hi, std::string doc) {
    return add<double>(std::move(key), access, OptionSpec::Type::kNumber, std::move(unit), lo, hi, std::move(doc));
  }
  template <class Access>
  OptionTable& integer(std::string key, Access access, double lo, double hi, std::string doc) {
    return add<int>(std::move(key), access, OptionSpec::Type::kInteger, "-", lo, hi, std::move(doc));
  }
  template <class Access>
  OptionTable& boolean(std::string key, Access access, std::string doc) {
    return add<bool>(std::move(key), access, OptionSpec::Type::kBoolean, "-", 0, 1, std::move(doc));
  }
  /// An enum option named in the job by one of `names` (names[i] is the enum's value i).
  template <class Access>
  OptionTable& choice(std::string key, Access access, std::vector<std::string> names, std::string doc) {
    using E = std::remove_reference_t<decltype(access(std::declval<T&>()))>;
    add<E>(std::move(key), access, OptionSpec::Type::kChoice, "-", 0, static_cast<double>(names.size()) - 1, std::move(doc));
    specs_.back().choices = std::move(names);
    return *this;
  }
  const std::vector<OptionSpec>& specs() const { return specs_; }

 private:
  template <class V, class Access>
  OptionTable& add(std::string key, Access access, OptionSpec::Type type, std::string unit, double lo, double hi, std::string doc) {
    OptionSpec s;
    s.key = std::move(key);
    s.type = type;
    s.unit = std::move(unit);
    s.min = lo;
    s.max = hi;
    s.doc = std::move(doc);
    s.get = [access](const std::any& a) {
      T& o = const_cast<T&>(std::any_cast<const T&>(a));
      if constexpr (std::is_enum_v<V>)
        return static_cast<double>(static_cast<int>(access(o)));
      else
        return static_cast<double>(access(o));
    };
    s.set = [access](std::any& a, double v) {
      V& field = access(std::any_cast<T&>(a));
      if constexpr (std::is_enum_v<V>)
        field = static_cast<V>(static_cast<int>(v));
      else
        field = static_cast<V>(v);
    };
    const T defaults{};
    s.default_value = s.get(std::any(defaults));
    specs_.push_back(std::move(s));
    return *this;
  }
  std::vector<OptionSpec> specs_;
};

/// The options of every method of a calibration, by method name. Each value is the method's own
/// options struct T, which names its method as `static constexpr const char* kMethod`.
class MethodOptionsMap {
 public:
  /// The options of T's method, created with T's defaults on first use.
  template <class T>
  T& get() {
    auto it = values_.find(T::kMethod);
    if (it == values_.end()) it = values_.emplace(T::kMethod, std::any(T{})).first;
    return std::any_cast<T&>(it->second);
  }
  /// T's defaults when they were never set.
  template <class T>
  const T& get() const {
    static const T defaults{};
    auto it = values_.find(T::kMethod);
    return it == values_.end() ? defaults : std::any_cast<const T&>(it->second);
  }
  /// Type-erased access for the registry's generic code (job parser, validation, listing):
  /// `defaults` is used when the method's options were never set.
  const std::any& at(const std::string& method, const std::any& defaults) const {
    auto it = values_.find(method);
    return it == values_.end() ? defaults : it->second;
  }
  std::any& at(const std::string& method, const std::any& defaults) {
    auto it = values_.find(method);
    if (it == values_.end()) it = values_.emplace(method, defaults).first;
    return it->second;
  }

 private:
  std::map<std::string, std::any> values_;
};

// ---- what a method reports ----------------------------------------------------------------

/// A residual drawn as an arrow in the report's plan view (and its histograms): at a plan
/// position, the residual before and after the calibration.
struct PlanResidual {
  std::string label;                                     ///< e.g. "tie 7 on strip 2"
  double x_m = 0, y_m = 0;                               ///< where it is drawn [m]
  Vec3 before_m = Vec3::Zero(), after_m = Vec3::Zero();  ///< [m]
};
/// A place marked in the report's plan view (a patch centre, a target).
struct PlanMark {
  std::string label;
  double x_m = 0, y_m = 0;  ///< [m]
};

/// The part of a Summary that one method owns. Built by the method after the solve.
class MethodSection {
 public:
  virtual ~MethodSection() = default;
  /// The method's name (the registry key), or "control" for ground control.
  virtual std::string method() const = 0;
  /// A clause of BriefReport, e.g. "12 ties / 40 observations (0 rejected)".
  virtual std::string brief() const = 0;
  /// The method's part of FullReport (plain text, ends with a newline; may be empty).
  virtual std::string text(const AdjustmentSummary& summary) const = 0;
  /// The method's keys of the result file, as the text of one JSON object whose members join
  /// the result's top level (e.g. {"planes": {...}}).
  virtual std::string resultJson(const AdjustmentSummary& summary) const = 0;
  /// The method's section of the HTML report (escaped HTML; may be empty).
  virtual std::string html(const AdjustmentSummary& summary) const = 0;
  /// Warnings for the report: rejected input, outliers found (one sentence each).
  virtual std::vector<std::string> warnings() const { return {}; }
  /// Findings that make the result doubtful (one sentence each): the verdict's reasons
  /// (MountingCalibrator::Summary::verdict) and the report's warnings.
  virtual std::vector<std::string> doubts() const { return {}; }
  /// Observations flagged as outliers [-].
  virtual int outliers() const { return 0; }
  /// Residual arrows and marks for the report's plan view (empty: none).
  virtual std::vector<PlanResidual> planResiduals(const CalibrationData& data) const {
    (void)data;
    return {};
  }
  virtual std::vector<PlanMark> planMarks() const { return {}; }
  /// Per-laser intrinsics the method estimated, by laser id (empty: none); `apply` and
  /// `evaluate` apply them with the mounting.
  virtual LaserCorrections laserCorrections() const { return {}; }
};

// ---- the module ---------------------------------------------------------------------------

/// The job's inputs that a method reads (top-level job keys, SPEC §4), already loaded into
/// CalibrationData by the job layer.
struct MethodInput {
  std::string job_key;  ///< e.g. "ties", "planes", "targets"; empty: the method needs none
  /// A word that may stand for the file (e.g. "auto" for "planes"); empty: none.
  std::string keyword;
  std::string doc;       ///< one line for `mountcal methods`
  bool required = true;  ///< a job naming the method without it is bad input
};

/// The noise a planner assumes, for a method to set its observation σ from it.
struct NoiseHint {
  double point_sigma_m = 0.0;    ///< σ of a point along the surface normal [m]
  double pick_sigma_xy_m = 0.0;  ///< σ of a hand-picked plan position [m]
  double pick_sigma_z_m = 0.0;   ///< σ of a pick's interpolated height [m]
};

struct MethodContext;

/// One run of a method: the observation sources it built, and its section after the solve.
class MethodRun {
 public:
  virtual ~MethodRun() = default;
  /// The sources that have observations to add (empty: nothing usable).
  virtual std::vector<ObservationSource*> sources() = 0;
  /// A starting value for the estimated parameters (MountingIndex order [m, rad]), or null.
  virtual const std::array<double, 6>* start() const { return nullptr; }
  /// The method's Summary section; called once the sources are finished (or when nothing was
  /// usable, with what was rejected).
  virtual std::shared_ptr<const MethodSection> section() const = 0;
  /// Why nothing was usable, when sources() is empty (for the summary's message).
  virtual std::string nothingUsable() const { return "no usable observation"; }
};

/// What a method sees when it runs.
struct MethodContext {
  const CalibrationData& data;
  const std::any& options;                        ///< the method's own options struct
  const MountingAdjustment::Options& adjustment;  ///< the shared stochastic model, solver and analysis
  int threads = 0;                                ///< for building observations (0: every core)
  /// Ground control points not claimed by another method of the run (Method::claimedGcps).
  const std::vector<GroundControlPoint>& unclaimed_gcps;
};

/// A calibration method. Stateless: the registry holds one instance per method.
class Method {
 public:
  virtual ~Method() = default;
  /// Registry key and job name, e.g. "planes".
  virtual std::string name() const = 0;
  /// One line for `mountcal methods`.
  virtual std::string description() const = 0;
  /// The job input it reads.
  virtual MethodInput input() const { return {}; }
  /// Earlier job keys of its options object (read with a deprecation notice).
  virtual std::vector<std::string> legacyOptionKeys() const { return {}; }
  /// True for a module that runs whenever its input is present, without being named in
  /// "method" (ground control).
  virtual bool implicit() const { return false; }
  /// Its options struct with the defaults, and the declaration of its job options.
  virtual std::any defaultOptions() const = 0;
  virtual const std::vector<OptionSpec>& options() const = 0;
  /// The job input's value was given (e.g. "auto" for planes): set what it implies.
  virtual void adoptInput(const std::string& value, std::any* options) const { (void)value, (void)options; }
  /// Checks relations between options beyond their declared ranges (ranges are checked by
  /// the registry). False with a message naming the option.
  virtual bool validate(const std::any& options, std::string* error) const {
    (void)options, (void)error;
    return true;
  }
  /// True when these options estimate per-laser intrinsics (a laser block in the adjustment).
  /// One calibration holds one such block: MountingCalibrator::Options::IsValid refuses two
  /// methods that each would estimate one (their corrections would disagree, and `apply` could
  /// carry only one).
  virtual bool estimatesLaserIntrinsics(const std::any& options) const {
    (void)options;
    return false;
  }
  /// A planner's noise: sets the method's observation σ from it.
  virtual void adoptNoise(const NoiseHint& noise, std::any* options) const { (void)noise, (void)options; }
  /// Ground control points (by id) that this method observes itself (the ties with a GCP's
  /// id); the others go to the ground-control module.
  virtual std::set<std::string> claimedGcps(const CalibrationData& data) const {
    (void)data;
    return {};
  }
  /// Builds the method's observations. Throws InvalidInput for inconsistent data.
  virtual std::unique_ptr<MethodRun> run(const MethodContext& context) const = 0;
};

/// Every registered method, in registration order (built-in first).
const std::vector<std::shared_ptr<const Method>>& registeredMethods();
/// The method of that name, or null.
const Method* findMethod(const std::string& name);
/// Registers a method; throws InvalidInput if its name is taken. Not thread-safe: register
/// before calibrating (MethodRegistration does so at start-up).
void registerMethod(std::shared_ptr<const Method> method);
/// "vtpm, planes, …" of the methods a job may name (implicit modules left out).
std::string methodNames();
/// Checks `options` (the method's options struct) against its declared ranges and the
/// method's own validation; the message names the method and the option.
bool validateMethodOptions(const Method& method, const std::any& options, std::string* error);

/// The registered methods as text (`mountcal methods`): per method its description, job input
/// and every option with its default, unit and range.
std::string describeMethods();

/// Registers a method when the program starts: `static MethodRegistration r(std::make_shared<M>());`
struct MethodRegistration {
  explicit MethodRegistration(std::shared_ptr<const Method> method) { registerMethod(std::move(method)); }
};

}  // namespace mountcal
