#!/usr/bin/env bash
# fuzz.sh — build the libFuzzer targets (tests/fuzz) with clang, AddressSanitizer
# and UndefinedBehaviorSanitizer, and run each for N minutes from a seed corpus:
#   shot:       every shot in shots/, tests/shots/, tests/cli/ and tests/cli/bad/
#   mesh:       every mesh under 64 KB in assets/ and tests/meshes/ (first byte: the extension)
#   checkpoint: the checkpoints of a two-frame run of tests/cli/cut.yaml
# One target at a time, one fuzzing process, under nice -n 19. A crash stops
# libFuzzer; the script keeps the input (build-fuzz/crashes/<target>-crash-*)
# and starts the target again until its minutes are spent.
#   usage: tools/fuzz.sh [minutes per target, default 1] [target ...]
#   e.g.   tools/fuzz.sh 30 shot mesh
# Each crash found becomes a regression test: put the input under
# tests/fuzz/crashes/ and list it in tests/fuzz/crashes/EXPECT.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
minutes=${1:-1}
shift || true
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(shot mesh checkpoint)
build="$here/build-fuzz"

# clang and its fuzzer runtime (Debian: clang-14, libclang-rt-14-dev, libomp-14-dev)
need=()
for p in clang-14 libclang-rt-14-dev libomp-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  echo "fuzz: installing ${need[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${need[@]}" >&2
fi

# pointer-overflow is left out: src/rigid/seed_rays.c:200 adds 0 to a NULL
# array (out->c before the first crossing), which clang reports on every rigid seeding
san="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize=pointer-overflow -fno-sanitize-recover=undefined"
san="$san -fno-omit-frame-pointer"
# KERF_FUZZ_NOBUILD=1: run the targets as built (e.g. while the tree is being edited)
if [ -z "${KERF_FUZZ_NOBUILD:-}" ]; then
  cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DKERF_FUZZ=ON -DKERF_NATIVE=OFF \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_C_FLAGS="$san" -DCMAKE_CXX_FLAGS="$san" >/dev/null
  nice -n 19 cmake --build "$build" -j "$(nproc)" --target fuzz_shot fuzz_mesh fuzz_checkpoint kerf >&2
fi

# ---- seed corpora (read-only; what the fuzzer finds goes to corpus/<target>) ----
seeds="$build/seeds"
rm -rf "$seeds"
mkdir -p "$seeds/shot" "$seeds/mesh" "$seeds/checkpoint" "$build/crashes"
for f in "$here"/shots/*.yaml "$here"/tests/shots/*.yaml "$here"/tests/shots/*.json \
         "$here"/tests/cli/*.yaml "$here"/tests/cli/bad/*.yaml; do
  [ -f "$f" ] && cp "$f" "$seeds/shot/$(basename "$(dirname "$f")")_$(basename "$f")"
done
for f in "$here"/assets/*.* "$here"/tests/meshes/*.*; do
  # the big scans (bunny, armadillo: MB) cost seconds an execution; small meshes cover every format
  [ "$(stat -c %s "$f")" -gt 65536 ] && continue
  case "$f" in
    *.obj) b='\000' ;; *.ply) b='\001' ;; *.stl) b='\002' ;; *.off) b='\003' ;; *) continue ;;
  esac
  { printf "$b"; cat "$f"; } > "$seeds/mesh/$(basename "$(dirname "$f")")_$(basename "$f")"
done
tiny="$build/seed_run"
rm -rf "$tiny"
if ! ASAN_OPTIONS=detect_leaks=0 OMP_NUM_THREADS=1 nice -n 19 "$build/kerf" run "$here/tests/cli/cut.yaml" \
     --out "$tiny" --frames 1001-1002 --set output.surface=false --set output.images=false > "$build/seed_run.log" 2>&1; then
  echo "fuzz: the seed run failed (see $build/seed_run.log)" >&2
  exit 1
fi
cp "$tiny"/checkpoints/*.kfc "$seeds/checkpoint/"

# ---- run each target for its minutes ------------------------------------------
status=0
for t in "${targets[@]}"; do
  exe="$build/fuzz_$t"
  [ -x "$exe" ] || { echo "fuzz: no target '$t' (shot, mesh, checkpoint)" >&2; exit 2; }
  mkdir -p "$build/corpus/$t"
  log="$build/fuzz_$t.log"
  : > "$log"
  end=$(( $(date +%s) + minutes * 60 ))
  runs=0 crashes=0 execs=0
  while :; do
    left=$(( end - $(date +%s) ))
    [ "$left" -le 0 ] && break
    runs=$((runs + 1))
    rc=0
    LSAN_OPTIONS=suppressions="$here/tests/fuzz/lsan.supp" ASAN_OPTIONS=detect_leaks=1 \
      OMP_NUM_THREADS=1 nice -n 19 "$exe" -max_total_time="$left" -timeout=30 \
      -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$build/crashes/$t-" \
      "$build/corpus/$t" "$seeds/$t" >> "$log" 2>&1 || rc=$?
    n=$(grep -a 'stat::number_of_executed_units' "$log" | awk '{s += $2} END {print s + 0}')
    execs=$n
    [ "$rc" -eq 0 ] && break
    crashes=$((crashes + 1))
    echo "fuzz: $t stopped (exit $rc) at $(( minutes * 60 - end + $(date +%s) )) s; see $log" >&2
  done
  echo "fuzz $t: $minutes min, $execs executions, $crashes crashes, $(ls "$build/corpus/$t" | wc -l) corpus files"
  [ "$crashes" -gt 0 ] && status=1
done
ls "$build"/crashes/ 2>/dev/null | sed 's/^/fuzz: kept /' >&2 || true
exit $status
