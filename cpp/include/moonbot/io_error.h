// The core's one I/O error type, shared by every reader and writer of files (images, DEMs), so
// that none of them depends on another for it. The bindings map it to Python's OSError.
#pragma once

#include <stdexcept>

namespace moonbot {

/// A file could not be written or read; the message names the path. Maps to Python's OSError.
class IoError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace moonbot
