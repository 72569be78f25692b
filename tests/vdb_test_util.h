/// @file vdb_test_util.h
/// @brief Helpers shared by the VDB reader tests.
#pragma once

#include <cstdlib>
#include <string>

#include <gtest/gtest.h>

#include "plugin/vdb/vdb_isolate.h"
#include "plugin/vdb/vdb_reader.h"

/// Isolated loads run the reader for tests (tests/vdb_reader_for_tests.cpp), which does @p what
/// (NIMBUS_TEST_READER_DOES there: "segv", "hang", "junk", ...) before it reads; nullptr: the
/// real reader again.
inline void useReaderForTests(const char* what) {
    if (what) {
        ::setenv("NIMBUS_TEST_READER_DOES", what, 1);
        nimbus::vdb::detail::setReaderForTests(NIMBUS_TEST_READER);
    } else {
        ::unsetenv("NIMBUS_TEST_READER_DOES");
        nimbus::vdb::detail::setReaderForTests("");
    }
}

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
