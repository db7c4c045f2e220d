#pragma once
/// \file io/atomic_file.hpp
/// Writing files so that a failed run never leaves a half file over a good one.

#include <string>

namespace mountcal::io {

/// Writes `content` to `path` through a temporary file in the same directory, flushed and then
/// renamed over `path`. Throws FileError naming `path` when any step fails; the previous
/// content of `path`, if any, is then untouched.
void writeFileAtomically(const std::string& path, const std::string& content);

}  // namespace mountcal::io
