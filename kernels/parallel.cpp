// SPDX-License-Identifier: Apache-2.0
#include "parallel.h"

#include <tbb/task_arena.h>

namespace vfit {

int parallel_thread_count() { return tbb::this_task_arena::max_concurrency(); }

} // namespace vfit
