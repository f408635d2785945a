// Checker installation and the rate-limited consultation behind the core's interrupt
// polls (see interrupt.hpp).
#include "pcl_rg/interrupt.hpp"

namespace pcl_rg {

namespace {

// The innermost scope installed on this thread; none on OpenMP workers.
thread_local InterruptScope* current_scope = nullptr;

constexpr std::uint32_t kMaxStride = 1u << 20;
constexpr std::chrono::microseconds kFastClock{250};
constexpr std::chrono::microseconds kSlowClock{2000};

}  // namespace

const char* Interrupted::what() const noexcept { return "interrupted"; }

InterruptScope::InterruptScope(InterruptChecker checker)
    : owner_(detail::this_thread_key()), checker_(checker), outer_(current_scope) {
    last_clock_ = std::chrono::steady_clock::now();
    // Calls shorter than one interval never consult the checker.
    next_check_ = last_clock_ + kCheckInterval;
    current_scope = this;
}

InterruptScope::~InterruptScope() { current_scope = outer_; }

bool InterruptScope::consult(bool counted) noexcept {
    const auto now = std::chrono::steady_clock::now();
    if (counted) {
        const auto since = now - last_clock_;
        if (since < kFastClock && stride_ < kMaxStride)
            stride_ *= 2;
        else if (since > kSlowClock && stride_ > 1)
            stride_ /= 2;
        countdown_ = stride_;
    }
    last_clock_ = now;
    if (now < next_check_) return false;
    next_check_ = now + kCheckInterval;
    bool stop = true;  // a checker that fails cannot say "go on"
    try {
        stop = checker_ != nullptr && checker_();
    } catch (...) {
    }
    if (stop) stopped_.store(true, std::memory_order_relaxed);
    return stop;
}

Interruption::Interruption() noexcept : scope_(current_scope) {}

}  // namespace pcl_rg
