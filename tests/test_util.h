/// @file test_util.h
/// @brief Small assertions shared by the test files.
#pragma once

#include <cstdio>
#include <string>

#include <sys/wait.h>

#include <gtest/gtest.h>

/// Succeeds when `part` occurs in `text`; the failure message shows the whole text.
inline testing::AssertionResult contains(const std::string& text, const std::string& part) {
    if (text.find(part) != std::string::npos) return testing::AssertionSuccess();
    return testing::AssertionFailure() << "\"" << part << "\" not found in:\n" << text;
}

/// Output and exit code of a run of the nimbus command (NIMBUS_CLI_PATH).
struct CliRun {
    int exitCode = -1;
    std::string output; ///< stdout and stderr
};

/// Runs `nimbus args` through the shell, with optional `VAR=value ...` environment in front.
inline CliRun runNimbus(const std::string& args, const std::string& env = "") {
    CliRun r;
    const std::string cmd =
        (env.empty() ? "" : env + " ") + std::string(NIMBUS_CLI_PATH) + " " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    if (!p) return r;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
    const int st = pclose(p);
    r.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
}
