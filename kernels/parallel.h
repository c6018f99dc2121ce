// SPDX-License-Identifier: Apache-2.0
#pragma once
/// \file
/// The TBB parallel helper: every data-parallel primitive is written as a serial range kernel
/// `kernel(begin, end)` and run through this thin driver with a named grain size, so the serial
/// entry stays available to tests and the parallel one adds nothing but the split.

#include <cstddef>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace vfit {

/// Runs `kernel(begin, end)` over [0, count) in parallel chunks of at least `grain` items.
/// The kernel must write only to outputs owned by its own range (no shared mutation).
/// count == 0 does nothing.
template <typename RangeKernel>
void parallel_for_range(std::size_t count, std::size_t grain, const RangeKernel& kernel) {
  if (count == 0) return;
  if (count <= grain) {
    kernel(std::size_t{0}, count);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { kernel(r.begin(), r.end()); });
}

/// Number of worker threads TBB will use in the current arena, under the process's
/// tbb::global_control limit (an Engine's thread count, `vfit --threads N`).
int parallel_thread_count();

} // namespace vfit
