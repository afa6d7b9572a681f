#!/usr/bin/env bash
# Installs the Debian 12 packages rtu needs when any is missing. As root it runs apt-get; otherwise it names the
# packages and exits non-zero. Usage: scripts/setup.sh
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config   # toolchain
  ccache                                         # compiler cache: rebuilds of unchanged sources (CI's two builds)
  libglm-dev libcli11-dev nlohmann-json3-dev libstb-dev libassimp-dev  # libraries of the tool
  libjpeg62-turbo-dev                            # JPEG textures (libjpeg-turbo; stb decodes PNG)
  catch2 libembree-dev                           # tests; Embree is the independent oracle and benchmark peer
  assimp-testmodels                              # the real meshes used by tests and benchmarks
  libcgal-demo                                   # CGAL's demo meshes (bunny, armadillo, elephant in OFF) of the
                                                 # benchmark suite; scripts/cgal_meshes.sh extracts them
  libnanoflann-dev libgmp-dev                    # the query tests' oracles: a k-d tree, exact rationals
  verilator yosys                                # the RTL box unit: simulation and tests (rtl_sim/), synthesis
  gnuplot-nox                                    # Pareto and scaling plots (rtusim pareto|report, bench/)
  chromium                                       # headless browser: the report page test (report_browser)
  clang libclang-rt-14-dev                       # libFuzzer targets with ASan + UBSan (preset fuzz, tests/fuzz/)
  pybind11-dev python3-dev python3-numpy         # the Python module rtu (python/), built with pybind11
  python3-pandas python3-matplotlib python3-pytest  # its DataFrames, examples/ plots and pytest tests
  slurm-wlm munge                                # sweeps as a Slurm job array: the cluster test starts a
                                                 # single-node Slurm (scripts/slurm_local.sh, docs/guide/cluster.md)
  python3-distributed                            # Dask: rtu.sweep_on with a Dask cluster's executor, and its test
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
if [ "$(id -u)" -ne 0 ]; then
  echo "rtu setup: missing Debian packages: ${missing[*]}" >&2
  echo "rtu setup: install them with: sudo apt-get install -y ${missing[*]}" >&2
  exit 1
fi
echo "rtu setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
