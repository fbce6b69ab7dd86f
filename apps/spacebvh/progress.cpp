// SPDX-License-Identifier: MIT
#include "progress.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "options.hpp"
#include "run_report.hpp"
#include "spacebvh/error.hpp"

namespace spacebvh::cli {

namespace {

// "42s", "3m05s", "1h02m".
std::string duration_text(double seconds) {
    char text[32];
    const long whole = long(seconds + 0.5);
    if (whole < 60)
        std::snprintf(text, sizeof text, "%lds", whole);
    else if (whole < 3600)
        std::snprintf(text, sizeof text, "%ldm%02lds", whole / 60, whole % 60);
    else
        std::snprintf(text, sizeof text, "%ldh%02ldm", whole / 3600, (whole % 3600) / 60);
    return text;
}

}  // namespace

Progress::Progress(std::string label, const CommonOptions& common)
    : label_(std::move(label)),
      terminal_(isatty(STDERR_FILENO)),
      enabled_(!common.quiet && (terminal_ || common.progress)),
      start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
    if (drawn_ && terminal_) std::fprintf(stderr, "\r\033[K");
}

void Progress::update(double fraction) {
    if (!enabled_) return;
    const double elapsed = milliseconds_since(start_) / 1000.0;
    if (terminal_ && elapsed < 1.0) return;  // only work over about a second gets a bar
    std::lock_guard lock(mutex_);
    fraction = std::clamp(fraction, 0.0, 1.0);
    // The ETA assumes the rest goes at the average rate so far.
    const std::string left =
        fraction > 0.01 ? "~" + duration_text(elapsed * (1.0 - fraction) / fraction) + " left" : "estimating time left";
    if (terminal_) {
        constexpr int kWidth = 30;
        const int filled = int(fraction * kWidth);
        std::fprintf(stderr, "\r%s [%.*s%*s] %3.0f%%  %s elapsed, %s\033[K", label_.c_str(), filled,
                     "##############################", kWidth - filled, "", fraction * 100.0,
                     duration_text(elapsed).c_str(), left.c_str());
    } else {
        if (drawn_ && elapsed - last_line_seconds_ < 5.0 && fraction < 1.0) return;
        last_line_seconds_ = elapsed;
        std::fprintf(stderr, "%s %3.0f%%  %s elapsed, %s\n", label_.c_str(), fraction * 100.0,
                     duration_text(elapsed).c_str(), left.c_str());
    }
    std::fflush(stderr);
    drawn_ = true;
}

std::function<void(double)> Progress::callback() {
    if (!enabled_) return {};
    return [this](double fraction) { update(fraction); };
}

namespace {

std::atomic<bool> interrupted{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the SIGINT handler may only touch a lock-free atomic");

extern "C" void on_interrupt(int) { interrupted.store(true); }

}  // namespace

InterruptScope::InterruptScope() {
    struct ::sigaction action {};
    action.sa_handler = on_interrupt;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESETHAND;  // the first Ctrl-C asks; the second one kills
    sigaction(SIGINT, &action, &previous_);
}

InterruptScope::~InterruptScope() {
    // After a Ctrl-C the default action stays, so that a second one still kills while we unwind.
    if (!interrupted.load()) sigaction(SIGINT, &previous_, nullptr);
}

const std::atomic<bool>* interrupt_flag() { return &interrupted; }

void throw_if_interrupted() {
    if (interrupted.load()) throw Cancelled("interrupted");
}

}  // namespace spacebvh::cli
