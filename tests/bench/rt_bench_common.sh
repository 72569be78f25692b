# rt_bench_common.sh: what the GPU-pass benchmarks share (sourced by rt_vs_cpu.sh, rt_skip.sh,
# rt_baked_vs_direct.sh and rt_accumulate.sh).

# rt_bench_init WIDTHxHEIGHT: sets `scene` (the default scene), `w`, `h` and `tmp` (a folder
# removed when the script exits).
rt_bench_init() {
    local here
    here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
    scene="$here/examples/scenes/cumulus.toml"
    w=${1%x*}
    h=${1#*x}
    tmp=$(mktemp -d)
    trap 'rm -rf "$tmp"' EXIT
}

# The seconds `nimbus rt` prints for each frame on the GPU, from its output on stdin.
rt_gpu_seconds() { sed -n 's/^frame [0-9]*: [0-9x]*, \([0-9.]*\) s on the GPU.*/\1/p'; }

# rt_medians NAME_A "times ..." NAME_B "times ...": the medians of two interleaved series and
# their ratio, one line.
rt_medians() {
    python3 - "$@" <<'PY'
import statistics, sys
na, a, nb, b = sys.argv[1:5]
ma = statistics.median(float(x) for x in a.split())
mb = statistics.median(float(x) for x in b.split())
print(f"median {na} {ma:.4f} s, {nb} {mb:.4f} s, {na}/{nb} {ma / mb:.2f}")
PY
}
