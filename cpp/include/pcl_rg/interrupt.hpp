// Stopping a long call of the core at safe points (Ctrl-C in Python), without the
// core seeing Python: the caller installs a checker for its thread (InterruptScope),
// the algorithms poll it (Interruption) and throw Interrupted where unwinding is safe.
//
// The rules the algorithms follow:
//   * only the thread that installed the checker ever calls it (OpenMP workers have
//     none; the calling thread is thread 0 of every team it opens), rate-limited, so a
//     poll costs a few instructions;
//   * inside an OpenMP region nothing throws: every thread polls the shared flag and
//     skips its remaining iterations once a stop was seen, and after the region the
//     calling thread throws Interrupted (Interruption::check);
//   * each thread of a region polls its own copy of the Interruption
//     (firstprivate(interruption)): the original sits on the calling thread's stack,
//     in cache lines that thread keeps writing;
//   * serial loops call check() directly; loops of a few nanoseconds per iteration poll
//     once per block of iterations; a poll between stages, which may be seconds apart
//     (PCL's classes and nanoflann's tree build cannot be polled inside), is check_now()
//     or poll_interrupt().
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <exception>
#include <thread>

namespace pcl_rg {

namespace detail {
// The calling thread's identity, compared on every poll: the thread pointer (one
// instruction, distinct for every live thread) where the compiler gives it, else
// std::thread::id (a library call).
#if defined(__GNUC__) && (defined(__x86_64__) || defined(__aarch64__))
using ThreadKey = const void*;
inline ThreadKey this_thread_key() noexcept { return __builtin_thread_pointer(); }
#else
using ThreadKey = std::thread::id;
inline ThreadKey this_thread_key() noexcept { return std::this_thread::get_id(); }
#endif
}  // namespace detail

/// Thrown by the core, at a safe point, once the calling thread's checker asked to
/// stop. Outputs are then partly written and must be discarded.
class Interrupted : public std::exception {
   public:
    const char* what() const noexcept override;
};

/// Returns true when the current call should stop. Called on the installing thread
/// only, at most every InterruptScope::kCheckInterval, never after it returned true.
using InterruptChecker = bool (*)();

/// Installs `checker` for the calling thread while alive (innermost scope wins).
class InterruptScope {
   public:
    static constexpr std::chrono::milliseconds kCheckInterval{20};

    explicit InterruptScope(InterruptChecker checker);
    ~InterruptScope();
    InterruptScope(const InterruptScope&) = delete;
    InterruptScope& operator=(const InterruptScope&) = delete;

    /// True once the checker asked to stop (any thread).
    bool stop_requested() const noexcept { return stopped_.load(std::memory_order_relaxed); }

    /// Any thread: true once a stop was requested; on the installing thread it also
    /// consults the checker when one is due, reading the clock only every few calls (for
    /// loops). Never throws.
    bool poll() noexcept {
        if (stopped_.load(std::memory_order_relaxed)) return true;
        if (detail::this_thread_key() != owner_) return false;
        if (--countdown_ > 0) return false;
        return consult(true);
    }

    /// As poll(), but reads the clock on every call (for polls between stages).
    bool poll_now() noexcept {
        if (stopped_.load(std::memory_order_relaxed)) return true;
        if (detail::this_thread_key() != owner_) return false;
        return consult(false);
    }

   private:
    bool consult(bool counted) noexcept;

    // Read by every thread of a team on every poll; written once. Its own cache line, so
    // the owner's bookkeeping below does not evict it from the other cores.
    alignas(64) std::atomic<bool> stopped_{false};
    const detail::ThreadKey owner_;
    const InterruptChecker checker_;
    InterruptScope* const outer_;
    // Owner only. Polls between clock reads, doubled or halved so that the clock is read
    // about once a millisecond however far apart the polls of a loop are.
    alignas(64) std::uint32_t stride_ = 16;
    std::uint32_t countdown_ = 16;
    std::chrono::steady_clock::time_point last_clock_;
    std::chrono::steady_clock::time_point next_check_;
};

/// The calling thread's innermost InterruptScope (or none) for one call of the core:
/// take it on the calling thread, before any OpenMP region that polls it.
class Interruption {
   public:
    Interruption() noexcept;

    /// Any thread, also inside OpenMP regions: true once a stop was requested (then skip
    /// the remaining work). Meant for loops: cheap, as only every few calls read the clock.
    /// Never throws.
    bool requested() const noexcept { return scope_ != nullptr && scope_->poll(); }

    /// Outside OpenMP regions, in loops and right after a region that polled:
    /// throws Interrupted once a stop was requested.
    void check() const {
        if (requested()) throw Interrupted();
    }

    /// Outside OpenMP regions, between stages: as check(), but the checker is consulted
    /// whenever it is due, however few calls came before.
    void check_now() const {
        if (scope_ != nullptr && scope_->poll_now()) throw Interrupted();
    }

   private:
    InterruptScope* scope_;
};

/// Interruption().check_now(): a poll between stages of the calling thread.
inline void poll_interrupt() { Interruption().check_now(); }

}  // namespace pcl_rg
