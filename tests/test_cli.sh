#!/usr/bin/env bash
# test_cli.sh — the kerf command end to end: a bad shot is refused with every
# problem at file:line:col and nothing written; a run writes its frames; a run
# killed mid-way and resumed ends bit for bit where an uninterrupted run ends.
#   usage: test_cli.sh <kerf binary> <tests dir>
set -u
kerf=$1
tests=$2
work=$(mktemp -d /tmp/kerf_cli.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}

cp "$tests/cli/tiny.yaml" "$tests/cli/broken.yaml" "$work/"
cd "$work"

# --- bad input: exit 2, all errors with locations, nothing written -----------
"$kerf" run broken.yaml > out.txt 2> err.txt
rc=$?
check "bad shot exits 2 (got $rc)" test $rc -eq 2
check "dx error at its line:col" grep -q "^broken.yaml:5:[0-9]*: error: .*dx" err.txt
check "undefined material at its line:col, with a suggestion" grep -q "^broken.yaml:9:[0-9]*: error: .*jely.*jelly" err.txt
check "the offending line is echoed" grep -q "material: jely" err.txt
check "nothing written for a bad shot" test ! -e broken
"$kerf" check broken.yaml > /dev/null 2>&1
check "kerf check exits 2 on the same shot" test $? -eq 2
"$kerf" run tiny.yaml --set sim.cfl=abc > /dev/null 2> err.txt
check "a bad --set exits 2 and names the override" bash -c "grep -q -- '--set' err.txt && ! test -e tiny"
"$kerf" run > /dev/null 2>&1
check "no shot is a usage error (2)" test $? -eq 2
"$kerf" frobnicate > /dev/null 2>&1
check "unknown command is a usage error (2)" test $? -eq 2
"$kerf" help shot | grep -q "sim.dx"
check "kerf help shot lists the keys" test $? -eq 0
"$kerf" check tiny.yaml > check.txt 2>&1
check "kerf check accepts a good shot" grep -q "ok" check.txt

# --- a full run ---------------------------------------------------------------
"$kerf" run tiny.yaml --out full > run.log 2>&1
check "full run exits 0" test $? -eq 0
check "twelve particle frames" test "$(ls full/particles/*.ply 2>/dev/null | wc -l)" -eq 12
check "twelve checkpoints" test "$(ls full/checkpoints/*.kfc 2>/dev/null | wc -l)" -eq 12
check "frame log line per frame (not a terminal)" test "$(grep -c '^frame 10' run.log)" -eq 11
check "no temporaries left" test -z "$(find full -name '*.tmp-*')"

# --- killed and resumed -------------------------------------------------------
"$kerf" run tiny.yaml --out killed > kill.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do # wait for frame 1003's checkpoint, then kill hard
    [ -e killed/checkpoints/tiny.1003.kfc ] && break
    sleep 0.05
done
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null
check "the killed run left frame 1003" test -e killed/checkpoints/tiny.1003.kfc
check "the kill came before the end" test ! -e killed/checkpoints/tiny.1012.kfc
"$kerf" run tiny.yaml --out killed --resume > resume.log 2>&1
check "resume exits 0" test $? -eq 0
check "resume says where it continues" grep -q "resuming after frame" resume.log
check "resumed final frame equals the uninterrupted one, bit for bit" \
    cmp -s full/particles/tiny.1012.ply killed/particles/tiny.1012.ply
check "resumed final checkpoint equals the uninterrupted one" \
    cmp -s full/checkpoints/tiny.1012.kfc killed/checkpoints/tiny.1012.kfc

# --- a resume refuses checkpoints made from other settings --------------------
"$kerf" run tiny.yaml --out full --resume --set materials.jelly.E=3e4 > other.log 2>&1
check "changed settings are not resumed from" grep -q "different shot settings" other.log

echo "$fails failed"
exit $((fails > 0))
