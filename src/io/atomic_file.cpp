#include "mountcal/io/atomic_file.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "mountcal/core/error.hpp"

namespace mountcal::io {

void writeFileAtomically(const std::string& path, const std::string& content) {
  std::random_device rd;
  const std::string tmp = path + ".tmp-" + std::to_string(rd() % 1000000u);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw FileError(path, "", std::string("cannot create: ") + std::strerror(errno));
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      throw FileError(path, "", "write failed (disk full?)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    throw FileError(path, "", "cannot rename the temporary file into place: " + why);
  }
}

bool samePath(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) return fs::equivalent(a, b, ec);
  const fs::path ca = fs::weakly_canonical(fs::absolute(a, ec), ec), cb = fs::weakly_canonical(fs::absolute(b, ec), ec);
  return ca == cb;
}

void writeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& files) {
  for (std::size_t i = 0; i < files.size(); ++i)
    for (std::size_t k = 0; k < i; ++k)
      if (samePath(files[i].first, files[k].first))
        throw FileError(files[i].first, "", "is written twice by this run (also as " + files[k].first + ")");
  std::random_device rd;
  const std::string tag = ".tmp-" + std::to_string(rd() % 1000000u);
  std::vector<std::pair<std::string, std::string>> temps;  // (temporary, target)
  auto removeTemps = [&] {
    for (const auto& t : temps) std::remove(t.first.c_str());
  };
  for (const auto& [path, content] : files) {  // 1. every temporary file
    const std::string tmp = path + tag;
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) {
      const std::string why = std::strerror(errno);
      removeTemps();
      throw FileError(path, "", "cannot create: " + why);
    }
    temps.emplace_back(tmp, path);
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) {
      removeTemps();
      throw FileError(path, "", "write failed (disk full?)");
    }
  }
  placeFilesAtomically(temps);  // 2. each in place, all or nothing
}

void placeFilesAtomically(const std::vector<std::pair<std::string, std::string>>& temporaries) {
  namespace fs = std::filesystem;
  auto removeTemps = [&] {
    for (const auto& t : temporaries) std::remove(t.first.c_str());
  };
  for (std::size_t i = 0; i < temporaries.size(); ++i)
    for (std::size_t k = 0; k < i; ++k)
      if (samePath(temporaries[i].second, temporaries[k].second)) {
        removeTemps();
        throw FileError(temporaries[i].second, "", "is written twice by this run (also as " + temporaries[k].second + ")");
      }
  // The previous content of each target is kept aside until all are in place.
  std::vector<std::string> backups(temporaries.size());
  std::size_t placed = 0;
  auto undo = [&] {
    for (std::size_t k = placed; k-- > 0;) {
      std::error_code ec;
      if (!backups[k].empty())
        fs::rename(backups[k], temporaries[k].second, ec);
      else
        fs::remove(temporaries[k].second, ec);
    }
    removeTemps();
  };
  for (; placed < temporaries.size(); ++placed) {
    const auto& [tmp, path] = temporaries[placed];
    std::error_code ec;
    if (fs::exists(path, ec)) {
      backups[placed] = tmp + ".previous";
      fs::rename(path, backups[placed], ec);
      if (ec) {
        backups[placed].clear();
        undo();
        throw FileError(path, "", "cannot replace the existing file: " + ec.message());
      }
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
      const std::string why = std::strerror(errno);
      if (!backups[placed].empty()) fs::rename(backups[placed], path, ec);
      undo();
      throw FileError(path, "", "cannot rename the temporary file into place: " + why);
    }
  }
  for (const std::string& b : backups)
    if (!b.empty()) std::remove(b.c_str());
}

}  // namespace mountcal::io
