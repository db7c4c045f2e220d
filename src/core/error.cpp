#include "mountcal/core/error.hpp"

#include <sstream>

namespace mountcal {

namespace {
std::string outOfRangeMessage(double t, double a, double b) {
  std::ostringstream msg;
  msg.precision(15);
  msg << "time " << t << " s is outside the trajectory [" << a << ", " << b
      << "] s; mountcal does not extrapolate (check the time offset and the time encoding)";
  return msg.str();
}
std::string fileMessage(const std::string& path, const std::string& location, const std::string& message) {
  return location.empty() ? path + ": " + message : path + ":" + location + ": " + message;
}
}  // namespace

TimeOutOfRange::TimeOutOfRange(double time_s, double start_s, double end_s)
    : Error(outOfRangeMessage(time_s, start_s, end_s)), time_s_(time_s) {}

FileError::FileError(std::string path, std::string location, const std::string& message)
    : Error(fileMessage(path, location, message)), path_(std::move(path)), location_(std::move(location)) {}

}  // namespace mountcal
