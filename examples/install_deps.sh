#!/usr/bin/env bash
# Installs the Debian 12 packages Nimbus needs to build, render and test, and only those that
# are missing. Run as root (or with sudo available). Safe to run again: a no-op when all are present.
set -euo pipefail

PACKAGES=(
  cmake g++ make pkg-config git
  libtbb-dev libglm-dev                                  # core
  libopenimageio-dev openimageio-tools libopencolorio-dev # plugin: EXR, colour
  libtomlplusplus-dev libcli11-dev                       # plugin: scene files, command line
  libopenvdb-dev libnanovdb-dev libboost-iostreams-dev   # plugin/vdb: VDB reading, baking
  liblog4cplus-dev                                       # plugin/vdb: OpenVDB's log without colours, on stderr
  libembree-dev libtinyobjloader-dev                     # plugin/geom: surfaces, instances
  libgtest-dev libbenchmark-dev glslang-tools            # tests, benchmarks, GLSL kernel checks
  libegl-dev libopengl-dev libgl1-mesa-dri               # tests: GLSL parity on headless GL (llvmpipe)
  libglfw3-dev xvfb nlohmann-json3-dev                   # examples/realtime_viewer (optional target); its test runs it under Xvfb
  gnuplot-nox                                            # nimbus converge --plot
  imagemagick fonts-dejavu-core                          # examples/automaton_preview.sh: contact sheet (montage), GIF
  clang libclang-rt-14-dev                               # tests: libFuzzer, ASan, UBSan (tests/fuzz)
  python3 python3-numpy                                  # examples/python (ctypes host of libnimbus.so)
  slurm-wlm munge                                        # tests: the farm test on a real Slurm scheduler
  blender                                                # plugin/blender: the add-on's headless tests (Blender 3.4, ~60 packages)
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install_deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get -o DPkg::Lock::Timeout=600 update -qq
$SUDO apt-get -o DPkg::Lock::Timeout=600 install -y -qq --no-install-recommends "${missing[@]}"
