// SPDX-License-Identifier: MIT
// The one exception type of the library: every bad input (file, parameter, scene) is reported as an
// Error whose message says what is wrong and where (file and line or element).
// Header-only.
#pragma once

#include <stdexcept>
#include <string>

namespace spacebvh {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// A long operation stopped because its cancellation flag was set (BuildOptions::cancel; Ctrl-C in
// the CLI). Not a bad input: callers that asked for the stop catch it.
class Cancelled : public Error {
public:
    using Error::Error;
};

}  // namespace spacebvh
