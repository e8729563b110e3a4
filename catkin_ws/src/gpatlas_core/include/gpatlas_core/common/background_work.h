#pragma once

#include <functional>

namespace gpatlas_core {

// For threads whose work nobody is waiting for (collision map rebuilds, display meshes,
// measurements of a run): lowers the calling thread's scheduling priority for good (its nice
// value, by `nice_increment`), so that the steps of the exploration that are waited for get the
// cores first. False where the system refuses (the thread keeps its priority).
bool lowerCurrentThreadPriority(int nice_increment = 10);

// Runs `work` with the library's parallel loops (TBB) confined to the calling thread: TBB's
// shared worker threads keep their normal priority, and a background computation spread over
// them would still take the cores from the planner and the model updates.
void runOnThisThreadOnly(const std::function<void()>& work);

}  // namespace gpatlas_core
