/// @file cancel.h
/// @brief Cooperative cancellation inside long loops: a flag the host sets (SIGTERM, SIGINT),
/// polled cheaply in step loops, tracking walks, per-pixel sample loops, grid builds and solver
/// iterations, so a render stops within milliseconds whatever the scene (a 1e-9 step, a medium
/// scaled by 1e12, millions of samples per pixel). docs/stability.md has the measured latencies.
///
/// A poll costs an increment and a test; the flag itself (a relaxed atomic load, a plain load on
/// x86) is read once every kEvery polls. Once it has been seen set, every later poll says so.
///
/// @code
///   CancelPoll poll{cancel};
///   for (;;) { if (poll()) return; ... one step ... }
/// @endcode
#pragma once

#include <atomic>
#include <cstdint>

namespace nimbus {

/// True when `flag` is set (null: never).
inline bool cancelRequested(const std::atomic<bool>* flag) {
    return flag && flag->load(std::memory_order_relaxed);
}

/// A counter over a cancellation flag: operator() reads the flag every kEvery calls.
struct CancelPoll {
    static constexpr std::uint32_t kEvery = 256; ///< a power of two
    const std::atomic<bool>* flag = nullptr;
    std::uint32_t count = 0;
    bool stopped = false;

    bool operator()() {
        if (stopped) return true;
        if (!flag || (++count & (kEvery - 1)) != 0) return false;
        stopped = flag->load(std::memory_order_relaxed);
        return stopped;
    }
    /// Reads the flag now (at the start of a walk, between stages).
    bool now() {
        if (!stopped && flag) stopped = flag->load(std::memory_order_relaxed);
        return stopped;
    }
};

/// Whether a segment walker (RayVolumes, the photons' scaled walk) has been cancelled: asked
/// by marchSegments and sampleTmaj every kEvery steps (a counter in a register; the walker
/// reads the flag); walkers without a poll never are.
template <class Segments> inline bool walkCancelled(Segments& s) {
    if constexpr (requires { s.cancelled(); })
        return s.cancelled();
    else
        return false;
}

} // namespace nimbus
