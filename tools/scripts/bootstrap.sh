#!/usr/bin/env bash
# Sets up a Debian 12 machine for AVATAR/TAU, builds it, and then either runs
# the main job ("demo") or the whole test suite ("test").
#
#   bash tools/scripts/bootstrap.sh demo   # install what is missing, build, run the main job
#   bash tools/scripts/bootstrap.sh test   # install what is missing, build, run ctest
#
# Environment: BUILD_DIR (default build), JOBS (default: number of cores).
set -euo pipefail

mode=${1:-}
case "$mode" in
  demo|test) ;;
  *) echo "usage: $0 demo|test" >&2; exit 2 ;;
esac

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${BUILD_DIR:-$root/build}
jobs=${JOBS:-$(nproc)}

# Debian packages the build, the tests and the demo need.
packages=(
  build-essential cmake ninja-build pkg-config ccache
  libopencv-dev libdc1394-dev libtinyxml2-dev nlohmann-json3-dev libyaml-cpp-dev
  libboost-dev libboost-program-options-dev liblog4cpp5-dev libssl-dev zlib1g-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libaravis-dev aravis-tools libusb-1.0-0-dev
  clang libclang-rt-14-dev
  tmux
  opencv-doc        # real stereo checkerboard photographs for the calibration tests
  xvfb x11-apps libxtst6   # avatar-filtergui's window tests: an X server, xwd screenshots, XTEST input
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]})); then
  echo "== installing: ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo=sudo; fi
  $sudo apt-get update -q
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

echo "== configuring $build"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAVATAR_WERROR=ON \
      -DCMAKE_CXX_COMPILER_LAUNCHER=ccache >/dev/null
echo "== building with $jobs jobs"
cmake --build "$build" -j "$jobs"

if [ "$mode" = test ]; then
  echo "== running the test suite"
  ctest --test-dir "$build" --output-on-failure -j "$jobs"
  exit $?
fi

echo "== main job: TAUNet replays the bundled session, a TAUUnit client takes a snapshot"
exec bash "$root/tools/scripts/main-job.sh" "$build" "$build/demo"
