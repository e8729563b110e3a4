#include "gpatlas_core/planning/strategy_library.h"

#include "gpatlas_core/model/surface_model_factory.h"

#include <dlfcn.h>

#include <algorithm>
#include <map>
#include <mutex>

namespace gpatlas_core {

StrategyLibraryLoad loadStrategyLibrary(const std::string& path) {
  static std::mutex mutex;
  // Keyed by dlopen's handle, which is the same however the file is named (a bare name found on
  // LD_LIBRARY_PATH, a relative or absolute path, a symbolic link): its static initialisers ran
  // once, at the first load, so later loads answer with the names recorded then.
  static std::map<void*, StrategyLibraryLoad> loaded;
  StrategyLibraryLoad result;
  if (path.empty()) {
    result.message = "cannot load strategy library: no file name given";
    return result;
  }
  std::lock_guard<std::mutex> lock(mutex);
  const std::vector<std::string> before = strategyNames();
  const std::vector<std::string> models_before = surfaceModelNames();
  dlerror();
  // RTLD_NOW: an unresolved symbol is reported here, not as a crash in the middle of a run. A
  // name without '/' is searched for as dlopen does (LD_LIBRARY_PATH, as a catkin workspace's
  // setup file sets it).
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* reason = dlerror();
    result.message = "cannot load strategy library '" + path + "': " + (reason ? reason : "unknown dlopen error");
    return result;
  }
  const auto known = loaded.find(handle);
  if (known != loaded.end()) {
    dlclose(handle);  // the reference taken just now; the first load's stays
    return known->second;
  }
  // The names that appeared during the load are the library's. (A registerStrategy call from
  // another thread at the same moment would be counted too: load libraries before planning starts.)
  for (const std::string& name : strategyNames())
    if (std::find(before.begin(), before.end(), name) == before.end()) result.added.push_back(name);
  for (const std::string& name : surfaceModelNames())
    if (std::find(models_before.begin(), models_before.end(), name) == models_before.end())
      result.added_models.push_back(name);
  if (result.added.empty() && result.added_models.empty()) {
    result.message = "library '" + path +
                     "' registered no new strategy nor surface model (no GPATLAS_REGISTER_STRATEGY or "
                     "GPATLAS_REGISTER_SURFACE_MODEL, its names are taken, or it was already part of the program)";
    return result;
  }
  result.ok = true;
  loaded[handle] = result;
  return result;
}

}  // namespace gpatlas_core
