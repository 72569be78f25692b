#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang, AddressSanitizer + UBSan; build-fuzz/) and runs each
# for a bounded time or number of executions. A crash, leak, sanitizer report or timeout makes
# this script fail; libFuzzer leaves the input as build-fuzz/artifacts/<harness>/crash-* (fix the
# bug, then keep the input in tests/fuzz/regressions/<harness>/, which ctest replays).
#
#   tests/fuzz/run.sh                        # every harness, 60 s each
#   tests/fuzz/run.sh --seconds 30 scene obj # some harnesses
#   tests/fuzz/run.sh --runs 1000000 frames  # a number of executions instead of a time
#   tests/fuzz/run.sh --ci                   # CI: seed 1, 30 s per harness, one per core
#
# Corpora grow in build-fuzz/corpus/<harness>/, seeded from tests/fuzz/seeds/<harness>/ (and for
# the scene parser examples/scenes, for the VDB reader the small files of ../shared/data/vdb when
# that folder exists: they are copied into the build folder, never into the repository).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
seconds=60
runs=""
seed=""
ci=0
harnesses=()
while [ $# -gt 0 ]; do
    case "$1" in
    --seconds) seconds="$2"; shift 2 ;;
    --runs) runs="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --ci) ci=1; seed=1; shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    -*) echo "run.sh: unknown option $1" >&2; exit 2 ;;
    *) harnesses+=("$1"); shift ;;
    esac
done
if [ ${#harnesses[@]} -eq 0 ]; then
    harnesses=(scene frames obj vdb vdb_isolated)
    # CI leaves out the in-process VDB reader: OpenVDB's tree reader trusts the chunk sizes it
    # reads and allocates what they say (docs/fuzzing.md), the reason Nimbus reads untrusted files
    # in a child process; the isolated harness checks that path instead.
    [ "$ci" = 1 ] && harnesses=(scene frames obj vdb_isolated)
fi

command -v clang++ >/dev/null || { echo "run.sh: clang++ not found (apt install clang libclang-rt-14-dev)" >&2; exit 2; }
build="$root/build-fuzz"
# -O1 and line tables only (the sanitizers' stack traces keep file:line): the build took 295 s
# instead of 340 s with RelWithDebInfo's -O2 -g on 2 cores (2026-12-04)
CXX=clang++ CC=clang cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
    "-DCMAKE_C_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only -DNDEBUG" \
    -DNIMBUS_FUZZ=ON -DNIMBUS_BUILD_TESTS=OFF -DNIMBUS_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j"$(nproc)" --target $(printf 'fuzz_%s ' "${harnesses[@]}")

shared="$root/../shared/data/vdb"
# one harness: its corpus, its run, its log; the exit status says whether it found anything
run_one() {
    local h="$1"
    local corpus="$build/corpus/$h"
    local artifacts="$build/artifacts/$h/"
    mkdir -p "$corpus" "$artifacts"
    cp -n "$root/tests/fuzz/seeds/$h"/* "$corpus"/ 2>/dev/null || true
    [ -d "$root/tests/fuzz/regressions/$h" ] && cp -n "$root/tests/fuzz/regressions/$h"/* "$corpus"/ 2>/dev/null || true
    local maxlen=4096
    case "$h" in
    scene) cp -n "$root"/examples/scenes/*.toml "$corpus"/ ;;
    vdb|vdb_isolated)
        maxlen=200000
        if [ -d "$shared" ]; then
            find "$shared" -name '*.vdb' -size -150k -exec cp -n {} "$corpus"/ \;
        else
            echo "run.sh: $shared absent: the VDB corpus starts from tests/fuzz/seeds only"
        fi ;;
    esac
    local limit=(-max_total_time="$seconds")
    [ -n "$runs" ] && limit=(-runs="$runs")
    # CI: a bounded time, not a number of executions: inputs that reach the frame-spec sorting
    # with millions of frames run 50x slower under the fuzzer's comparison instrumentation
    # (docs/fuzzing.md), so a count of executions did not bound the time.
    [ "$ci" = 1 ] && limit=(-max_total_time=30)
    [ -n "$seed" ] && limit+=(-seed="$seed")
    echo "== fuzz_$h (${limit[*]}, corpus $corpus)"
    local log="$build/fuzz_$h.log"
    local asan=detect_leaks=1:abort_on_error=1
    # in process, an allocation over 2 GiB fails (std::bad_alloc from the harness's operator new)
    # as it would under the isolated child's memory limit, instead of ending the run (fuzz_vdb.cpp)
    local lsan=""
    # the isolated harness forks for every input, and a fork copies the fuzzer's page tables,
    # which grow with ASan's quarantine of freed memory (256 MB by default): with 32 MB, side by
    # side over 20 minutes, 29 executions a second instead of 18 (docs/fuzzing.md)
    [ "$h" = vdb_isolated ] && asan="$asan:quarantine_size_mb=32"
    if [ "$h" = vdb ]; then
        asan="$asan:allocator_may_return_null=1:max_allocation_size_mb=2048"
        # OpenVDB's own leak when a tree read throws (lsan_openvdb.supp); ours still reported
        lsan="suppressions=$root/tests/fuzz/lsan_openvdb.supp"
    fi
    local rc=0
    ASAN_OPTIONS="$asan" LSAN_OPTIONS="$lsan" UBSAN_OPTIONS=print_stacktrace=1 \
        "$build/tests/fuzz/fuzz_$h" "${limit[@]}" -max_len="$maxlen" -timeout=60 \
        -rss_limit_mb=3072 -artifact_prefix="$artifacts" -print_final_stats=1 \
        "$corpus" >"$log" 2>&1 || rc=1
    if [ $rc != 0 ]; then
        echo "fuzz_$h FAILED: see $log and $artifacts"
        tail -40 "$log"
    fi
    grep -E '^#[0-9]+\s+DONE|stat::number_of_executed_units|stat::peak_rss_mb' "$log" || tail -3 "$log"
    return $rc
}

# Harnesses run side by side, one per core (libFuzzer runs on one thread): on CI's 2 cores the
# four took 64 s instead of 120. Each one's report is printed whole, in the order named.
jobs=$(nproc)
running=0
for h in "${harnesses[@]}"; do
    if [ "$running" -ge "$jobs" ]; then
        wait -n || true
        running=$((running - 1))
    fi
    rm -f "$build/run_$h.rc"
    (if run_one "$h" >"$build/run_$h.out" 2>&1; then echo 0; else echo 1; fi >"$build/run_$h.rc") &
    running=$((running + 1))
done
wait
status=0
for h in "${harnesses[@]}"; do
    cat "$build/run_$h.out"
    case "$(cat "$build/run_$h.rc" 2>/dev/null)" in
    0) ;;
    1) status=1 ;; # its report says FAILED
    *) echo "fuzz_$h: the run did not finish"; status=1 ;;
    esac
done
exit $status
