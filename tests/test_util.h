/// @file test_util.h
/// @brief Small assertions and helpers shared by the test files: substring checks, runs of the
/// nimbus command, and a temporary folder per test.
#pragma once

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

/// Writes @p text to the file @p p (binary); throws when it cannot.
inline void writeText(const std::string& p, const std::string& text) {
    std::ofstream out(p, std::ios::binary);
    out << text;
    if (!out) throw std::runtime_error("test could not write " + p);
}

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

/// Runs a shell command line, stderr folded into the output.
inline CliRun runShell(const std::string& command) {
    CliRun r;
    FILE* p = popen((command + " 2>&1").c_str(), "r");
    if (!p) return r;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
    const int st = pclose(p);
    r.exitCode = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return r;
}

/// Runs `nimbus args` through the shell, with optional `VAR=value ...` environment in front.
inline CliRun runNimbus(const std::string& args, const std::string& env = "") {
    return runShell((env.empty() ? "" : env + " ") + std::string(NIMBUS_CLI_PATH) + " " + args);
}

/// Runs `nimbus args` (output discarded), sends it SIGINT after `ms` milliseconds and returns its
/// exit code (128 + the signal when a signal ended it).
inline int interruptNimbus(const std::string& args, int ms = 1500) {
    const std::string cmd =
        "exec " + std::string(NIMBUS_CLI_PATH) + " " + args + " >/dev/null 2>&1";
    const pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        execl("/bin/sh", "sh", "-c", cmd.c_str(), (char*)nullptr);
        _exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    kill(pid, SIGINT);
    int st = 0;
    waitpid(pid, &st, 0);
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

/// A fresh folder under the system temp folder, created on construction and removed with all it
/// holds on destruction. Its name is unique within the machine: nimbus_<tag>_<pid>_<suite>_<test>_
/// <counter>, where the test is the one running (if any) and the counter counts TempDirs made by
/// this process. Use it as a test fixture's member or as a local; it converts to the path.
class TempDir {
  public:
    explicit TempDir(const std::string& tag = "test") {
        static std::atomic<unsigned> counter{0};
        std::string name = "nimbus_" + tag + "_" + std::to_string(getpid());
        if (const auto* info = testing::UnitTest::GetInstance()->current_test_info())
            name += std::string("_") + info->test_suite_name() + "_" + info->name();
        name += "_" + std::to_string(counter++);
        for (char& c : name)
            if (c == '/') c = '_'; // parameterised tests are named Suite/Test/0
        path_ = std::filesystem::temp_directory_path() / name;
        std::filesystem::remove_all(path_);
        std::filesystem::create_directories(path_);
    }
    ~TempDir() {
        std::error_code ec; // never throw from a destructor; a leftover folder is harmless
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    const std::filesystem::path& path() const { return path_; }
    std::string string() const { return path_.string(); }
    operator const std::filesystem::path&() const { return path_; }
    std::filesystem::path operator/(const std::filesystem::path& name) const {
        return path_ / name;
    }

  private:
    std::filesystem::path path_;
};
