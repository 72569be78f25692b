/// @file atomic_file.h
/// @brief Atomic file output (temp file in the same directory, fsync, rename) and removal of
///        in-flight temp files on SIGINT/SIGTERM, so that an interrupted or failed render never
///        leaves an output file that looks valid.
///
/// A frame written with writeAtomically() either exists complete (fsynced before the rename; the
/// directory is fsynced after it) or not at all; a previous version of the file stays untouched
/// until the new one is complete. Temp files are hidden dot-files named
/// `.<name>.tmp-<host>-<pid>-<counter>` (host: 8 hex digits of the host name; the name's prefix
/// when the whole would pass NAME_MAX, 255): they never end in the output's extension (`find
/// -name '*.exr'` does not see them; image writers take the format from the final name), and a
/// legal output name always has a legal temp name.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace nimbus::io {

/// Writes @p finalPath atomically: creates the parent directories, calls @p writer with a temp
/// path in the same directory, fsyncs the temp file, renames it over @p finalPath and fsyncs the
/// directory. While the writer runs the temp path is in the process-wide in-flight registry (see
/// removeInFlightTempFiles()). If the writer throws, the temp file is removed and the exception
/// rethrown; @p finalPath is never touched.
/// @throws std::runtime_error naming the path and the system error (strerror) when a directory
///         cannot be created, the writer produced no file, fsync fails (e.g. disk full) or the
///         rename fails.
void writeAtomically(const std::string& finalPath,
                     const std::function<void(const std::string& tempPath)>& writer);

/// The temp path writeAtomically() would use next for @p finalPath (same directory,
/// `.<name>.tmp-<host>-<pid>-<counter>`, at most 255 bytes). Each call returns a new name.
std::string makeTempPath(const std::string& finalPath);

/// Removes the temp files that processes of this host which no longer run (a SIGKILLed frame)
/// left beside any of @p finalPaths; returns how many. Temp files of running processes and of
/// other hosts are left alone.
std::size_t removeStaleTempFiles(const std::vector<std::string>& finalPaths);

/// Unlinks every temp file currently being written by writeAtomically() in this process.
/// Async-signal-safe (a fixed array of paths, atomics and unlink(2) only): meant to be called from
/// a SIGINT/SIGTERM handler. Unregisters the removed entries.
void removeInFlightTempFiles() noexcept;

/// Number of temp files currently registered as in flight (for tests and diagnostics).
std::size_t inFlightTempFileCount() noexcept;

/// Installs SIGINT, SIGTERM and SIGHUP handlers that call removeInFlightTempFiles() and then
/// re-raise the signal with its default disposition (so the exit status still says "killed by
/// signal"). A program with its own handlers should call removeInFlightTempFiles() itself instead.
void installTempFileCleanupOnSignals();

} // namespace nimbus::io
