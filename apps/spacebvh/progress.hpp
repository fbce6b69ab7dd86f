// SPDX-License-Identifier: MIT
// What a long command shows and how it stops: a progress bar on stderr, and Ctrl-C turned into a
// clean stop.
#pragma once

#include <signal.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>

namespace spacebvh::cli {

struct CommonOptions;

// Progress on stderr for work over about a second: the fraction done, the time elapsed and the
// estimated time left. A bar redrawn in place when stderr is a terminal; with --progress also when it
// is not (then one line every few seconds); silent with --quiet. Thread-safe update().
class Progress {
public:
    Progress(std::string label, const CommonOptions& common);
    ~Progress();
    void update(double fraction);
    std::function<void(double)> callback();

private:
    std::string label_;
    bool terminal_;  // redraw in place
    bool enabled_;
    std::chrono::steady_clock::time_point start_;
    std::mutex mutex_;
    bool drawn_ = false;
    double last_line_seconds_ = 0;  // when the last line was written (not on a terminal)
};

// Ctrl-C during a build, trace or compare: while an InterruptScope lives, the first SIGINT sets a
// flag that builds (BuildConfig::cancel) and the commands' loops poll; they stop by throwing
// Cancelled and main exits with 130. The first SIGINT also restores the default action, so a second
// one kills the process. Outside a scope Ctrl-C kills as usual.
class InterruptScope {
public:
    InterruptScope();
    ~InterruptScope();
    InterruptScope(const InterruptScope&) = delete;
    InterruptScope& operator=(const InterruptScope&) = delete;

private:
    struct ::sigaction previous_ {};
};
const std::atomic<bool>* interrupt_flag();
void throw_if_interrupted();  // throws Cancelled once Ctrl-C was pressed

}  // namespace spacebvh::cli
