// SPDX-License-Identifier: Apache-2.0
// The implicit step's thread team (kernels/chunk_team.h): every chunk of every pass runs exactly
// once, with its own bounds, whatever the lane count and however many followers ever start.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <iostream>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "vfit/kernels/chunk_team.h"

namespace vfit {
namespace {

using Team = cloth_detail::ChunkTeam<8>;

// Runs `passes` passes on a team of `lanes`, pass p over n + p % 3 items in chunks of 8 (so a
// pass's bounds differ from the last one's); each chunk adds (p + 1) to every item of its range
// and checks its bounds. Returns the items' sums, which equal expected_sums() exactly when every
// chunk ran once per pass; `bad_bounds` counts chunks called with bounds other than
// [8c, min(n_p, 8c + 8)) (a lane running a pass with another pass's bounds).
std::vector<long> run_passes(std::size_t lanes, std::size_t n, int passes, std::size_t& bad_bounds,
                             std::size_t& team_lanes) {
  std::vector<long> items(n + 2, 0);
  std::atomic<std::size_t> bad{0};
  Team::lead(lanes, [&](Team& team) {
    team_lanes = team.lanes();
    for (int p = 0; p < passes; ++p) {
      const std::size_t np = n + std::size_t(p % 3);
      team.run(np, [&items, &bad, np, p](std::size_t c, std::size_t b, std::size_t e) {
        if (b != 8 * c || e != std::min(np, 8 * c + 8)) bad.fetch_add(1);
        for (std::size_t i = b; i < e; ++i)
          items[i] += p + 1; // chunks own disjoint items: no two lanes write one
      });
    }
  });
  bad_bounds = bad.load();
  return items;
}

std::vector<long> expected_sums(std::size_t n, int passes) {
  std::vector<long> items(n + 2, 0);
  for (int p = 0; p < passes; ++p)
    for (std::size_t i = 0; i < n + std::size_t(p % 3); ++i)
      items[i] += p + 1;
  return items;
}

TEST(ChunkTeam, EveryChunkOfEveryPassRunsOnceWithItsBounds) {
  for (std::size_t lanes : {1, 2, 3, 5}) {
    for (std::size_t n : {1, 7, 8, 9, 100, 1001}) {
      const int passes = 400; // many short passes: a lane late for one must run none of it
      std::size_t bad = 0, team_lanes = 0;
      const std::vector<long> items = run_passes(lanes, n, passes, bad, team_lanes);
      EXPECT_EQ(team_lanes, lanes);
      EXPECT_EQ(bad, 0u) << lanes << " lanes, n = " << n;
      EXPECT_EQ(items, expected_sums(n, passes)) << lanes << " lanes, n = " << n;
    }
  }
}

TEST(ChunkTeam, TheLeaderRunsEveryChunkWhenNoFollowerCanStart) {
  // One thread in all: the follower tasks can start only when the leader waits for them at
  // the end, after the last pass, so every pass's chunks are the leader's (it claims the
  // followers' shares too) and the team still leaves cleanly.
  tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
  std::size_t bad = 0, team_lanes = 0;
  const std::vector<long> items = run_passes(4, 333, 50, bad, team_lanes);
  EXPECT_EQ(bad, 0u);
  EXPECT_EQ(items, expected_sums(333, 50));
}

TEST(ChunkTeam, FollowersAsleepBetweenDistantPassesWakeForTheNext) {
  // Passes 3 ms apart: longer than a follower spins and yields (~0.1 ms), so it sleeps on the
  // pass counter between them and must be woken by each. In every pass the leader's first chunk
  // waits (up to 2 s) until a chunk of the follower's share has been run by another thread: a
  // lost wake-up leaves the follower asleep and the wait runs out.
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs two cores for the follower to run";
  tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
  const std::size_t n = 16 * 8; // 16 chunks: 0-7 the leader's share, 8-15 the follower's
  int woken = 0;
  Team::lead(2, [&](Team& team) {
    const std::thread::id leader = std::this_thread::get_id();
    for (int p = 0; p < 10; ++p) {
      std::this_thread::sleep_for(std::chrono::milliseconds(3));
      std::atomic<bool> follower_ran{false};
      bool seen = false;
      team.run(n, [&](std::size_t c, std::size_t, std::size_t) {
        if (c >= 8 && std::this_thread::get_id() != leader) follower_ran.store(true);
        if (c != 0) return;
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
        while (!follower_ran.load() && std::chrono::steady_clock::now() < until)
          std::this_thread::yield();
        seen = follower_ran.load();
      });
      woken += seen ? 1 : 0;
    }
  });
  EXPECT_EQ(woken, 10) << "passes in which the sleeping follower woke and ran its share";
}

TEST(ChunkTeam, LanesAreCappedByTheThreadsAndTheChunks) {
  tbb::global_control two(tbb::global_control::max_allowed_parallelism, 2);
  EXPECT_LE(Team::lanes_for(100), 2u);
  EXPECT_GE(Team::lanes_for(100), 1u);
  EXPECT_EQ(Team::lanes_for(1), 1u);
  EXPECT_EQ(Team::lanes_for(0), 1u);
}

TEST(ChunkTeam, AnExceptionInTheBodyStillDismissesTheFollowers) {
  bool caught = false;
  try {
    Team::lead(3, [&](Team& team) {
      team.run(100, [](std::size_t, std::size_t, std::size_t) {});
      throw std::runtime_error("body failed");
    });
  } catch (const std::runtime_error&) {
    caught = true;
  }
  EXPECT_TRUE(caught);
}

} // namespace
} // namespace vfit
