#!/usr/bin/env bash
# Installs what is missing, builds everything (Release, -j2) and runs the whole test suite under
# ctest, then the fuzz harnesses for a fixed number of executions (tests/fuzz/run.sh --ci). Tests
# that need ../shared/data/vdb skip with a message when it is absent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash examples/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2
cd build
ctest --output-on-failure -j2 --timeout 900
cd "$root"
# The fuzz harnesses for a fixed number of executions (clang, ASan + UBSan; docs/fuzzing.md).
bash tests/fuzz/run.sh --ci
