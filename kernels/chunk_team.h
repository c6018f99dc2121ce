// SPDX-License-Identifier: Apache-2.0
#pragma once
// Private to kernels/: a team of threads held for the length of one iterative solve, which
// runs its passes over fixed chunks without a TBB fork and join per pass. Not a public header.
//
// Why: the implicit step's CG runs two passes over the particles per iteration, each short on a
// garment-sized mesh. Run as two tbb::parallel_for calls per iteration, a worker went to sleep
// between passes: waking it (a futex call) cost the calling thread time on every pass, and the
// pass started before the worker did, so the caller ran most of its chunks. A team's followers
// spin between passes instead (they sleep only after a long gap, see follow()), for the step
// only, and each lane starts on its own contiguous share of the chunks, the same share in every
// pass, so its rows stay in its own cache.
//
// How: lead(lanes, body) runs body(team) on the calling thread (the leader) and enqueues
// lanes − 1 follower tasks. team.run(n, kernel) publishes a pass; every lane that has started
// claims chunks, from its own share first and then from the others' (so a follower that never
// started, or that the system preempts, costs at most the chunk it holds), and the leader
// returns when every chunk is done. Each chunk runs exactly once, by one lane, writing only its
// own outputs, so a pass gives the same bits as run_chunks() for any lane count. The atomics
// here are the team's synchronisation only; the kernels it runs use none.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <thread>

#include <tbb/global_control.h>
#include <tbb/task_group.h>

#include "parallel.h"

namespace vfit::cloth_detail {

// Fixed chunk of a team pass: particles [CHUNK·c, min(n, CHUNK·(c + 1))).
template <std::size_t CHUNK> class ChunkTeam {
public:
  // Most lanes a solve gets: the threads that may run (the arena's, capped by a
  // tbb::global_control), at most one per chunk of `chunks`.
  static std::size_t lanes_for(std::size_t chunks) {
    const auto threads = std::min(static_cast<std::size_t>(std::max(1, parallel_thread_count())),
                                  tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
    return std::max<std::size_t>(1, std::min(threads, chunks));
  }

  // Runs body(team) on the calling thread with lanes − 1 followers; returns once they left.
  template <typename Body> static void lead(std::size_t lanes, const Body& body) {
    ChunkTeam team(std::max<std::size_t>(1, lanes));
    tbb::task_group followers;
    for (std::size_t k = 1; k < team.m_lanes; ++k)
      followers.run([&team, k] { team.follow(k); });
    struct Dismiss { // also when body throws: the followers must leave before `team` dies
      ChunkTeam& team;
      tbb::task_group& followers;
      ~Dismiss() {
        team.m_stop.store(true, std::memory_order_seq_cst);
        team.m_pass.value.fetch_add(1, std::memory_order_seq_cst); // wakes the followers to leave
        team.m_pass.value.notify_all();
        followers.wait();
      }
    } dismiss{team, followers};
    body(team);
  }

  // Runs kernel(chunk, begin, end) over the fixed chunks of [0, n); returns when all are done.
  template <typename Kernel> void run(std::size_t n, const Kernel& kernel) {
    const std::size_t chunks = (n + CHUNK - 1) / CHUNK;
    if (chunks == 0) return;
    if (chunks > MAX_CHUNKS) { // beyond what a cursor holds: the leader alone (CHUNK·65,535 particles)
      for (std::size_t c = 0; c < chunks; ++c)
        kernel(c, c * CHUNK, std::min(n, (c + 1) * CHUNK));
      return;
    }
    const std::uint64_t pass = m_pass.value.load(std::memory_order_relaxed) + 1;
    m_n.store(n, std::memory_order_relaxed);
    m_context.store(&kernel, std::memory_order_relaxed);
    m_trampoline.store(&trampoline<Kernel>, std::memory_order_relaxed);
    for (std::size_t k = 0; k < m_lanes; ++k)
      m_cursor[k].value.store(cursor(pass, share_begin(k + 1, chunks), share_begin(k, chunks)),
                              std::memory_order_relaxed);
    m_done.value.store(0, std::memory_order_relaxed);
    m_pass.value.store(pass, std::memory_order_seq_cst);
    // Seq-cst with the follower's count then check: it sees the pass or is counted here.
    if (m_sleepers.load(std::memory_order_seq_cst) > 0) m_pass.value.notify_all();
    const std::size_t mine = work(0, pass);
    if (mine > 0) m_done.value.fetch_add(mine, std::memory_order_acq_rel);
    spin_until([&] { return m_done.value.load(std::memory_order_acquire) == chunks; });
  }

  std::size_t lanes() const { return m_lanes; }

private:
  explicit ChunkTeam(std::size_t lanes) : m_lanes(lanes), m_cursor(std::make_unique<Slot[]>(lanes)) {}

  struct alignas(64) Slot { // one cache line each: a lane's cursor is written by it alone, mostly
    std::atomic<std::uint64_t> value{0};
  };

  // A share's cursor: the pass it belongs to (bits 32-63), the end of the share (16-31) and its
  // next chunk (0-15), in one word, so that a claim reads the share's bounds with the pass they
  // belong to.
  static constexpr std::size_t MAX_CHUNKS = 0xffff;
  static std::uint64_t cursor(std::uint64_t pass, std::size_t end, std::size_t next) {
    return (pass << 32) | (std::uint64_t(end) << 16) | std::uint64_t(next);
  }
  std::size_t share_begin(std::size_t k, std::size_t chunks) const { return k * chunks / m_lanes; }

  // Spins, then yields, until done(): the lanes wait for each other microseconds at a time.
  // With `give_up`, returns false after that many yields instead (a follower then sleeps).
  static constexpr unsigned SPINS = 1u << 10; // pauses lasting about a pass or two
  static constexpr unsigned YIELDS = 64;
  template <typename Done> static bool spin_until(const Done& done, bool give_up = false) {
    for (unsigned k = 0; !done(); ++k) {
      if (k < SPINS) {
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#endif
      } else if (give_up && k >= SPINS + YIELDS) {
        return false;
      } else {
        std::this_thread::yield();
      }
    }
    return true;
  }

  template <typename Kernel> static void trampoline(const void* kernel, std::size_t c, std::size_t n) {
    (*static_cast<const Kernel*>(kernel))(c, c * CHUNK, std::min(n, (c + 1) * CHUNK));
  }

  // Lane k's part of `pass`: claims chunks from its own share, then from the others' in turn;
  // returns how many it ran. A claim is a compare-and-swap on a share's cursor, which names its
  // pass: a lane late for a pass finds the cursors moved on and runs nothing. A claim that
  // succeeds took a chunk not yet done, so the pass was still open when this lane read the
  // job's fields (the leader writes the next pass's only after every chunk is done), and they
  // are this pass's.
  std::size_t work(std::size_t k, std::uint64_t pass) {
    const std::size_t n = m_n.load(std::memory_order_relaxed);
    const void* context = m_context.load(std::memory_order_relaxed);
    const auto run_chunk = m_trampoline.load(std::memory_order_relaxed);
    std::size_t ran = 0;
    for (std::size_t step = 0; step < m_lanes; ++step) {
      std::atomic<std::uint64_t>& share = m_cursor[(k + step) % m_lanes].value;
      std::uint64_t seen = share.load(std::memory_order_acquire);
      for (;;) {
        if ((seen >> 32) != pass) return ran; // the pass is over: every chunk was claimed
        const std::size_t next = std::size_t(seen & 0xffff), end = std::size_t((seen >> 16) & 0xffff);
        if (next >= end) break;
        if (!share.compare_exchange_weak(seen, seen + 1, std::memory_order_acq_rel, std::memory_order_acquire))
          continue;
        run_chunk(context, next, n);
        ++ran;
        seen = share.load(std::memory_order_acquire);
      }
    }
    return ran;
  }

  // A follower: joins each pass published after it started, until the leader dismisses it.
  // It spins for the next pass, then yields, then sleeps on the pass counter (a busy machine, or
  // a long serial stretch of the leader's: the core goes back to the system, and the leader
  // wakes it with the next pass).
  void follow(std::size_t k) {
    std::uint64_t seen = 0;
    for (;;) {
      std::uint64_t pass = 0;
      const auto published = [&] {
        pass = m_pass.value.load(std::memory_order_seq_cst);
        return pass != seen;
      };
      if (!spin_until(published, true)) {
        m_sleepers.fetch_add(1, std::memory_order_seq_cst);
        while (!published())
          m_pass.value.wait(seen, std::memory_order_seq_cst);
        m_sleepers.fetch_sub(1, std::memory_order_seq_cst);
      }
      if (m_stop.load(std::memory_order_seq_cst)) return; // dismissed (no pass is left open then)
      seen = pass;
      const std::size_t ran = work(k, pass);
      if (ran > 0) m_done.value.fetch_add(ran, std::memory_order_acq_rel);
    }
  }

  const std::size_t m_lanes;
  std::unique_ptr<Slot[]> m_cursor; // one per lane's share
  Slot m_pass;                      // the last pass published (0: none yet)
  Slot m_done;                      // chunks of the current pass finished
  std::atomic<bool> m_stop{false};
  std::atomic<unsigned> m_sleepers{0}; // followers asleep on m_pass
  std::atomic<std::size_t> m_n{0};
  std::atomic<const void*> m_context{nullptr};
  std::atomic<void (*)(const void*, std::size_t, std::size_t)> m_trampoline{nullptr};
};

} // namespace vfit::cloth_detail
