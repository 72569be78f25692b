/// @file test_util.h
/// @brief Small assertions shared by the test files.
#pragma once

#include <string>

#include <gtest/gtest.h>

/// Succeeds when `part` occurs in `text`; the failure message shows the whole text.
inline testing::AssertionResult contains(const std::string& text, const std::string& part) {
    if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
    return testing::AssertionFailure() << "\"" << part << "\" not found in:\n" << text;
}
