#!/usr/bin/env bash
# Installs every Debian package reefgen needs to build, test and run.
# Idempotent: packages already present are left as they are.
set -euo pipefail

PKGS=(
  build-essential cmake ninja-build pkg-config
  libopencv-dev          # image I/O, resampling, colour conversion
  zlib1g-dev             # our own fast 8-bit PNG encoder (common/src/image_io.cpp)
  libopenexr-dev         # float height fields (.exr, channel Y)
  libgdal-dev gdal-bin   # GeoTIFF heights and layers (gis/); gdalinfo, gdaldem, gdal_contour check them in the tests
  nlohmann-json3-dev     # params <-> JSON
  libspdlog-dev          # logging
  libcli11-dev           # reefgen subcommands
  libgtest-dev           # unit tests (ctest)
  libbenchmark-dev       # optional micro-benchmarks
  libtorch-dev           # LibTorch 1.13 CPU (model/train/infer)
  libgloo-dev            # Gloo headers for LibTorch's c10d (data-parallel training); same version as the libgloo0 LibTorch links
  # Without it LibTorch falls back to the netlib reference BLAS and a pix2pix
  # training step is ~7x slower (7.0 s vs 1.0 s measured, docs/BENCHMARKS.md).
  # The OpenMP build shares libgomp's threads with LibTorch (no oversubscription).
  libopenblas0-openmp
  libdnnl-dev            # oneDNN directly: the fast inference engine (model/src/fast_unet.cpp)
  libcpp-httplib-dev     # reefgen studio's local web server
  nodejs                 # npm fetches three.js (the studio's 3D view) and playwright-core at configure time
  python3 python3-torch python3-numpy  # reference comparisons (scripts/reference); reefgen.torch's datasets
  python3-dev pybind11-dev             # the Python module `import reefgen` (python/)
  python3-pil                          # tests: the pix2pix dataset opens as pix2pix opens it (PIL)
  python3-onnx           # tests: the ONNX export passes onnx's checker (tests/cli_infer_models_test.sh)
  python3-opencv         # tests/cli_test.sh compares EXRs (bf16 vs fp32); scripts/paint_sketches.py
  python3-pip python3-venv python3-setuptools  # pip install . (pyproject.toml, setup.py; docs/PYTHON.md)
  slurm-wlm munge                      # tests: a real single-host SLURM cluster runs the dataset array and the training job (tests/slurm_test.sh)
  mono-mcs                             # tests: the Unity bundle's importer script compiles (tests/unity_importer_test.sh)
)

missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PKGS[@]} packages present" >&2
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
echo "install-deps: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
# npm comes with some nodejs builds and not with Debian's own: add Debian's if absent.
command -v npm >/dev/null || $SUDO apt-get install -y -qq --no-install-recommends npm >/dev/null || \
  echo "install-deps: no npm; the studio page will have no 3D view" >&2
echo "install-deps: done" >&2
