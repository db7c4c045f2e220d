#pragma once
/// \file error.hpp
/// The exceptions mountcal throws. Library code never prints and never exits: a caller gets
/// one of these, whose what() is a single line a user can act on.

#include <stdexcept>
#include <string>

namespace mountcal {

/// Base of every mountcal exception.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An argument or a data set violates a documented precondition (unsorted trajectory times,
/// non-finite values, an unknown laser id, ...). The message names the offending item.
class InvalidInput : public Error {
 public:
  using Error::Error;
};

/// A time outside the span of a trajectory. mountcal never extrapolates a trajectory.
class TimeOutOfRange : public Error {
 public:
  TimeOutOfRange(double time_s, double start_s, double end_s);
  double time_s() const noexcept { return time_s_; }

 private:
  double time_s_;
};

/// A file could not be read or written, or its content is malformed. `path()` is the file,
/// `location()` the line, record or byte where it went wrong (empty when it concerns the whole
/// file). what() reads "<path>:<location>: <message>".
class FileError : public Error {
 public:
  FileError(std::string path, std::string location, const std::string& message);
  const std::string& path() const noexcept { return path_; }
  const std::string& location() const noexcept { return location_; }

 private:
  std::string path_;
  std::string location_;
};

}  // namespace mountcal
