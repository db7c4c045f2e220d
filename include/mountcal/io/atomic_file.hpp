#pragma once
/// \file io/atomic_file.hpp
/// Writing files so that a failed run never leaves a half file over a good one.

#include <string>
#include <utility>
#include <vector>

namespace mountcal::io {

/// Writes `content` to `path` through a temporary file in the same directory, flushed and then
/// renamed over `path`. Throws FileError naming `path` when any step fails; the previous
/// content of `path`, if any, is then untouched.
void writeFileAtomically(const std::string& path, const std::string& content);

/// Writes several files all or nothing: every temporary file is written first, then each is
/// renamed over its path; when any step fails the files renamed so far get their previous
/// content back (or are removed when they did not exist) and FileError names the file that
/// failed. Two entries naming the same file are refused before anything is written.
void writeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& files);

/// Places files already written under temporary names, all or nothing: `temporaries[i].first`
/// (a finished temporary file) is renamed over `temporaries[i].second`. Each existing target is
/// kept aside until every file is in place; when any rename fails, the targets placed so far get
/// their previous content back (or are removed when they did not exist), every temporary file
/// is removed and FileError names the target that failed. Two entries naming the same target
/// are refused (FileError) before anything is renamed; the temporaries are then removed too.
void placeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& temporaries);

/// True when `a` and `b` name the same file: the same inode when both exist (links resolved),
/// otherwise the same absolute, normalised path (links of the existing part resolved).
bool samePath(const std::string& a, const std::string& b);

}  // namespace mountcal::io
