#include "gpatlas_core/common/background_work.h"

#include <tbb/task_arena.h>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>

namespace gpatlas_core {

bool lowerCurrentThreadPriority(int nice_increment) {
  // On Linux a thread has a nice value of its own, addressed by its thread id.
  const id_t thread = static_cast<id_t>(syscall(SYS_gettid));
  errno = 0;
  const int current = getpriority(PRIO_PROCESS, thread);
  if (current == -1 && errno != 0) return false;
  return setpriority(PRIO_PROCESS, thread, current + nice_increment) == 0;
}

void runOnThisThreadOnly(const std::function<void()>& work) {
  tbb::task_arena single(1);
  single.execute(work);
}

}  // namespace gpatlas_core
