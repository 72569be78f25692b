#!/bin/bash
# rt_gpu_pack.sh: `nimbus` with every shared library it loads, packed for a GPU machine that has
# a driver but none of Nimbus' dependencies (how `nimbus rt` reached the lent NVIDIA H200 of
# docs/realtime.md, "GPU frame times"). The C library stays behind (the target's is used, so
# it must be as new as Debian 12's glibc 2.36); the GL libraries travel as GLVND's dispatchers
# (libEGL, libOpenGL), which load the target's vendor driver.
#   tests/bench/rt_gpu_pack.sh BUILD_DIR OUT_DIR [PART_MB]
# Writes OUT_DIR/nimbus-rt.tar.xz.00, .01, ... (parts of at most PART_MB, default 50, for
# transfers with a size limit), OUT_DIR/unpack.sh, and the smoke1 VDB when the shared data
# folder is beside the repository. There:
#   bash unpack.sh DIR           # joins the parts, unpacks into DIR, writes DIR/nimbus
#   DIR/nimbus rt scene.toml ... # the wrapper sets the library path and, where NVIDIA's GLVND
#                                # file is found, __EGL_VENDOR_LIBRARY_FILENAMES
set -euo pipefail
build=${1:?usage: rt_gpu_pack.sh BUILD_DIR OUT_DIR [PART_MB]}
out=${2:?usage: rt_gpu_pack.sh BUILD_DIR OUT_DIR [PART_MB]}
part=${3:-50}
here=$(cd "$(dirname "$0")/../.." && pwd)
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/nimbus-rt/lib" "$stage/nimbus-rt/bin" "$out"
cp -a "$build"/nimbus "$build"/libnimbus*.so* "$stage/nimbus-rt/bin/"
# the libraries by the names the loader asks for (ldd's paths, links followed), glibc's own
# left out; TBB's allocator is loaded at run time when present
for f in "$build"/nimbus "$build"/libnimbus*.so; do ldd "$f"; done | awk '/=>/ {print $3}' |
    sort -u | grep -v -E "/(libc|libm|libpthread|libdl|librt|libresolv|ld-linux-x86-64)\.so" |
    grep -v "^$(cd "$build" && pwd)/" | while read -r lib; do cp -L "$lib" "$stage/nimbus-rt/lib/"; done
tbbmalloc=$(ldconfig -p | awk '/libtbbmalloc\.so\.2 / {print $NF; exit}')
[ -z "$tbbmalloc" ] || cp -L "$tbbmalloc" "$stage/nimbus-rt/lib/"
echo "rt_gpu_pack: $(ls "$stage/nimbus-rt/lib" | wc -l) libraries, $(du -sh "$stage/nimbus-rt" | cut -f1)"
rm -f "$out"/nimbus-rt.tar.xz.*
tar -C "$stage" -cf - nimbus-rt | xz -9 -T0 | split -b "${part}M" -d - "$out/nimbus-rt.tar.xz."
vdb="$here/../shared/data/vdb/openvdb_smoke1.vdb"
[ ! -e "$vdb" ] || cp "$vdb" "$out/"
cat >"$out/unpack.sh" <<'UNPACK'
#!/bin/bash
# unpack.sh DIR: the parts beside this file joined and unpacked into DIR; DIR/nimbus written
set -euo pipefail
dir=${1:?usage: unpack.sh DIR}
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$dir"
cat "$here"/nimbus-rt.tar.xz.* | xz -d -T0 | tar -x -C "$dir"
vendor=$(ls /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json \
    /usr/share/glvnd/egl_vendor.d/10_nvidia.json 2>/dev/null | head -1 || true)
cat >"$dir/nimbus" <<WRAP
#!/bin/sh
exec env LD_LIBRARY_PATH=$dir/nimbus-rt/lib:$dir/nimbus-rt/bin:/usr/local/nvidia/lib64 \
${vendor:+__EGL_VENDOR_LIBRARY_FILENAMES=$vendor} $dir/nimbus-rt/bin/nimbus "\$@"
WRAP
chmod +x "$dir/nimbus"
echo "unpack.sh: $dir/nimbus${vendor:+ (EGL vendor: $vendor)}"
UNPACK
chmod +x "$out/unpack.sh"
ls -la "$out"
