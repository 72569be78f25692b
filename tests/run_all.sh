#!/usr/bin/env bash
# Installs what is missing, builds everything (Release, -j2) and runs the whole test suite under
# ctest, then the fuzz harnesses for a fixed number of executions (tests/fuzz/run.sh --ci). Tests
# that need ../shared/data/vdb skip with a message when it is absent.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
# each stage's wall time on one line at the end (docs/tests.md: the CI budget)
start=$SECONDS
stages=""
stage() { stages="$stages $1 $((SECONDS - start)) s;"; start=$SECONDS; }
bash examples/install_deps.sh
stage "install:"
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2
stage "configure+build:"
cd build
ctest --output-on-failure -j2 --timeout 900
stage "ctest:"
cd "$root"
# The fuzz harnesses for a fixed number of executions (clang, ASan + UBSan; docs/fuzzing.md).
bash tests/fuzz/run.sh --ci
stage "fuzz build+run:"
echo "run_all.sh:$stages total $SECONDS s"
