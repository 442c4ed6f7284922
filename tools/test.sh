#!/usr/bin/env bash
# test.sh — set up, build, and run the whole test suite with ctest.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
# the CI build: every warning is an error
KERF_CMAKE_OPTIONS="-DKERF_WERROR=ON" "$here/tools/setup.sh"
cd "$here/build"
# one test at a time: each test already runs two OpenMP threads
status=0
ctest --output-on-failure --timeout 900 || status=1

# the fast subset (ctest -L fast) again in a second tree built with
# AddressSanitizer and UndefinedBehaviorSanitizer: any report fails its test
# (no recovery); leaks inside assimp and libfyaml are theirs (tests/fuzz/lsan.supp)
asan="$here/build-asan"
cmake -S "$here" -B "$asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DKERF_SANITIZE=address,undefined \
  >/dev/null
cd "$asan"
fast=$(ctest -N -L fast 2>/dev/null | sed -nE 's/^ *Test +#[0-9]+: (test_[a-z0-9_]+)$/\1/p' | grep -v '^test_cli')
# shellcheck disable=SC2086  # one target per word
cmake --build "$asan" -j "$(nproc)" --target kerf $fast >&2
ASAN_OPTIONS=detect_leaks=1 LSAN_OPTIONS=suppressions="$here/tests/fuzz/lsan.supp" UBSAN_OPTIONS=print_stacktrace=1 \
  ctest -L fast --output-on-failure --timeout 900 || status=1
exit $status
