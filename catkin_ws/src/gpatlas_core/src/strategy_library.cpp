#include "gpatlas_core/strategy_library.h"

#include <dlfcn.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <mutex>

namespace gpatlas_core {

StrategyLibraryLoad loadStrategyLibrary(const std::string& path) {
  static std::mutex mutex;
  static std::map<std::string, std::vector<std::string>> loaded;  // canonical path -> names it added
  StrategyLibraryLoad result;
  // A bare file name is left to dlopen's search (LD_LIBRARY_PATH, as set by a catkin workspace's
  // setup file); a path is made canonical so that one file loads once however it is named.
  std::string file = path;
  if (path.find('/') != std::string::npos) {
    std::error_code error;
    file = std::filesystem::canonical(path, error).string();
    if (error) {
      result.message = "cannot load strategy library '" + path + "': " + error.message();
      return result;
    }
  }
  std::lock_guard<std::mutex> lock(mutex);
  const auto known = loaded.find(file);
  if (known != loaded.end()) {
    result.ok = true;
    result.added = known->second;
    return result;
  }
  const std::vector<std::string> before = strategyNames();
  dlerror();
  // RTLD_NOW: an unresolved symbol is reported here, not as a crash in the middle of a run.
  if (path.empty() || !dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL)) {
    const char* reason = dlerror();
    result.message =
        "cannot load strategy library '" + path + "': " + (reason ? reason : "no file name given");
    return result;
  }
  for (const std::string& name : strategyNames())
    if (std::find(before.begin(), before.end(), name) == before.end()) result.added.push_back(name);
  if (result.added.empty()) {
    result.message = "strategy library '" + path +
                     "' registered no new strategy (no GPATLAS_REGISTER_STRATEGY, or its names are taken)";
    return result;
  }
  loaded[file] = result.added;
  result.ok = true;
  return result;
}

}  // namespace gpatlas_core
