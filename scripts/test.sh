#!/usr/bin/env bash
# Sets up (Debian packages), builds the `default` preset and runs every test, then the firmware tests under the
# `asan` preset. Usage: scripts/test.sh [ctest args]
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
cmake --preset default >/dev/null
cmake --build --preset default -j "$(nproc)"
ctest --preset default "$@"
# The command interface under AddressSanitizer + UndefinedBehaviorSanitizer: the ring and error-path tests and
# >= 10^5 random packets and register writes per engine (tests/firmware). RTU_SKIP_ASAN=1 skips this step.
if [[ "${RTU_SKIP_ASAN:-0}" != 1 ]]; then
  cmake --preset asan >/dev/null
  cmake --build --preset asan -j "$(nproc)" --target test_firmware
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    build/asan/tests/test_firmware
fi
