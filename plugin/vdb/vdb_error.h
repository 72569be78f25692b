/// @file vdb_error.h
/// @brief VdbError: the one exception type of plugin/vdb (reading, baking, frame sequences).
#pragma once

#include <stdexcept>

namespace nimbus::vdb {

/// Anything that prevents a grid from being read or written. what() names the file, the grid
/// when known, and what was found, e.g. `smoke.vdb: grid "density": is a level set (...)`.
class VdbError : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

} // namespace nimbus::vdb
