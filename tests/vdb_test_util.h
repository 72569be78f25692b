/// @file vdb_test_util.h
/// @brief Helpers shared by the VDB reader tests.
#pragma once

#include <string>

#include <gtest/gtest.h>

#include "plugin/vdb/vdb_reader.h"

/// The message of the VdbError that loadVdbGrid(o) throws, or "" (and a test failure).
inline std::string loadError(const nimbus::vdb::VdbLoadOptions& o) {
    try {
        nimbus::vdb::LoadedVdbGrid g = nimbus::vdb::loadVdbGrid(o);
        ADD_FAILURE() << "loading grid \"" << o.gridName << "\" of " << o.path
                      << " did not throw; it gave " << g.activeVoxelCount << " active voxels";
    } catch (const nimbus::vdb::VdbError& e) {
        return e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "not a VdbError: " << e.what();
    }
    return "";
}
