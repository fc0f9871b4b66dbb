#!/usr/bin/env bash
# Installs every Debian 12 package fringe needs to build, test and benchmark.
# Idempotent: when everything is already installed it does nothing (no network),
# so the README commands can be re-run cheaply. Run as root (or with sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config clang-format
  libopencv-dev libopencv-contrib-dev   # image I/O, imgproc, calib3d, structured_light (peer)
  libeigen3-dev                         # linear algebra
  libnanoflann-dev                      # k-d trees
  libembree-dev                         # ray casting in the simulator
  libtbb-dev                            # threads
  libcli11-dev                          # command line
  nlohmann-json3-dev                    # JSON
  libyaml-cpp-dev libtinyxml2-dev       # untrusted YAML / XML calibration files (bounded parsers)
  zlib1g-dev                            # the reports' 3D view: its arrays deflated
  libgtest-dev libgmock-dev             # tests
  libceres-dev                          # nonlinear least squares (calibration, marker adjustment)
  libopen3d-dev                         # FPFH + RANSAC coarse alignment, Poisson meshing; peer in benchmarks
  libcgal-dev                           # meshing alternative measured against Open3D
  libmeshoptimizer-dev                  # the reports' 3D view: fast mesh decimation
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-pytest   # Python module
  python3-distributed                   # fringe.batch: scan folders as tasks on a Dask cluster
  libaravis-dev                         # capture: GenICam cameras (GigE Vision, USB3 Vision)
  libsdl2-dev                           # capture: the projector window
  libx11-dev                            # capture tests: read the projector's screen back
  aravis-tools xvfb x11-utils iproute2  # capture tests: fake GigE Vision cameras, X server, ip
  chromium                              # the reports' 3D view tested in a real browser (headless)
)
# Node.js (>= 20, with npm) bundles the reports' 3D view and drives the browser tests
# (web/viewer/). The machine image's Node.js 20 is used when present; else Debian's.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  packages+=(nodejs npm)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
else
  echo "install-deps: installing ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

# The 3D view's npm packages (three, esbuild, playwright-core), pinned by package-lock.json;
# again only when the lock file changed since the last install (no network otherwise).
viewer="$(cd "$(dirname "$0")/.." && pwd)/web/viewer"
if ! cmp -s "$viewer/package-lock.json" "$viewer/node_modules/.fringe-installed-lock"; then
  echo "install-deps: npm ci in web/viewer"
  (cd "$viewer" && npm ci --no-audit --no-fund --loglevel=error &&
   cp package-lock.json node_modules/.fringe-installed-lock)
else
  echo "install-deps: web/viewer/node_modules up to date"
fi
