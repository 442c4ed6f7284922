#!/usr/bin/env bash
# test_shots.sh — every shipped shot (shots/*.yaml) passes `kerf check` at
# final quality (validated and seeded: exit 0 and its one "ok" line) and
# simulates one frame at preview quality (exit 0, that frame's checkpoint).
# The frame is made short (frames.fps = 1000: a few substeps) so the whole
# set runs in about half a minute; surfaces and images are left out.
#   usage: test_shots.sh <kerf binary> <repository root>
set -u
kerf=$1
root=$2
work=$(mktemp -d /tmp/kerf_shots.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0 n=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}
for shot in "$root"/shots/*.yaml; do
    name=$(basename "$shot" .yaml)
    n=$((n + 1))
    "$kerf" check "$shot" > "$work/$name.check" 2>&1
    rc=$?
    line=$(grep -E "^$shot: ok \\($name, [0-9]+ particles, frames [0-9]+-[0-9]+\\)$" "$work/$name.check")
    check "$name: kerf check exits 0 (got $rc) with its ok line" \
        bash -c "test $rc -eq 0 && test -n '$line' && test \"\$(grep -c . '$work/$name.check')\" -eq 1"
    [ $rc -eq 0 ] || sed 's/^/      /' "$work/$name.check"
    start=$(echo "$line" | sed -E 's/.*frames ([0-9]+)-.*/\1/')
    [ -n "$start" ] || start=1001
    next=$((start + 1))
    "$kerf" run "$shot" --quality preview --frames "$start-$next" --out "$work/out_$name" --set frames.fps=1000 \
        --set output.surface=false --set output.images=false > "$work/$name.run" 2>&1
    rc=$?
    check "$name: a one-frame preview run exits 0 (got $rc) and writes frame $next" \
        bash -c "test $rc -eq 0 && ls '$work/out_$name'/checkpoints/*.$next.kfc > /dev/null 2>&1 && \
                 grep -qE '^frame $next: [0-9]+ particles' '$work/$name.run'"
    [ $rc -eq 0 ] || tail -5 "$work/$name.run" | sed 's/^/      /'
done
check "the shipped shots were all found ($n)" test $n -ge 21
echo "$fails failed"
exit $((fails > 0))
