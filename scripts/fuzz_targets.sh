# The libFuzzer targets of tests/fuzz and the longest input each may be given (-max_len), sourced by
# scripts/test.sh and scripts/fuzz_long.sh. Without -max_len libFuzzer takes the largest seed's length (a few KiB
# here), so large and deeply nested inputs were never tried. The lengths, per input:
#  - scene_file, mesh_import: 1 MiB. Enough for JSON nested far past host::kMaxJsonDepth (64) and for Collada or
#    AC3D node chains deep enough (~4 * 10^4 levels under ASan) to overflow the importer's 64 MiB stack;
#  - device_image: 256 KiB, a BVH of thousands of nodes, up to the traversal stack's depth bound;
#  - texture: 64 KiB, images of up to a few hundred texels a side (PNG compresses far more);
#  - ray_file, command_processor, config, point_file: 64 KiB, 2048 rays (each traced on three devices), programs of thousands
#    of packets, lines of thousands of keys: larger only makes each run slower, the formats are flat.
# CI (scripts/test.sh) runs each target for a fixed number of inputs from a fixed seed, RTU_FUZZ_SEED, so that a
# commit's verdict does not depend on luck; the counts give each target about 5-8 s under ASan on one core of the
# CI machine (2 cores), measured from build/asan/fuzz-summary.txt. RTU_FUZZ_RUNS overrides every count.
# shellcheck shell=bash
RTU_FUZZ_SEED=${RTU_FUZZ_SEED:-20261204}
RTU_FUZZ_TARGETS=(scene_file mesh_import ray_file command_processor device_image config texture point_file)
rtu_fuzz_max_len() {
  case $1 in
    scene_file | mesh_import) echo 1048576 ;;
    device_image) echo 262144 ;;
    *) echo 65536 ;;
  esac
}
rtu_fuzz_runs() {
  if [[ -n ${RTU_FUZZ_RUNS:-} ]]; then
    echo "$RTU_FUZZ_RUNS"
    return
  fi
  # About 5-8 s each at the rates measured under ASan on this machine with the other core busy (exec/s:
  # scene_file 2.7k, mesh_import 160 (Assimp in a child process), ray_file 2.4k, command_processor 620,
  # device_image 10k, config 1k, texture 12k): half of what they were, to keep the test command under its 20
  # minutes (bench/results/test-time.md, run 7); scripts/fuzz_long.sh runs them open-ended.
  case $1 in
    scene_file) echo 20000 ;;
    mesh_import) echo 1250 ;;
    ray_file) echo 17500 ;;
    command_processor) echo 4500 ;;
    device_image) echo 75000 ;;
    config) echo 7500 ;;
    texture) echo 75000 ;;
    point_file) echo 10000 ;;
    *) echo 5000 ;;
  esac
}
