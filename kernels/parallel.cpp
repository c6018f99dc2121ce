// SPDX-License-Identifier: Apache-2.0
#include "parallel.h"

#include <algorithm>

#include <tbb/global_control.h>
#include <tbb/task_arena.h>

namespace vfit {

int parallel_thread_count() {
  // The arena's concurrency, under the process's limit (a tbb::global_control, such as an
  // Engine's thread count), which the arena's own figure does not show.
  const auto limit = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return static_cast<int>(
      std::min<std::size_t>(static_cast<std::size_t>(tbb::this_task_arena::max_concurrency()), limit));
}

} // namespace vfit
