#!/usr/bin/env bash
# test_mpi_kill.sh — one rank of a run over 3 MPI ranks killed (kill -9)
# while the run writes frames: the whole job stops within seconds with a
# message, said once (Open MPI's launcher ends the ranks by SIGTERM, which
# rank 0 catches; MPICH's by SIGKILL, which rank 0's watchdog answers), no
# rank is left waiting in a collective and no watchdog left behind; and
# `--resume` on 2 ranks continues from the last checkpoint written, ending
# bit for bit on the plain one-rank run's last checkpoint. A run that
# finishes says nothing of a stop; Ctrl-C of a healthy run on 2 ranks is
# said as an interruption (under Open MPI, which may drop the ranks' last
# line after Ctrl-C, at most once), and leaves nothing behind.
#   usage: test_mpi_kill.sh <kerf binary> <tests dir>
# The launcher and the helpers: tests/mpi/common.sh (exit 77 without one).
set -u
kerf=$1
tests=$2
work_prefix=kerf_mpi_kill
. "$tests/mpi/common.sh"
cp "$tests/mpi/drop.yaml" "$work/"
cd "$work"
last=1016
frames=(--set frames.end=$last)

# the pids of the kerf processes under a launcher's pid (Open MPI starts them
# as its children, MPICH under a proxy), from ps: no name matching elsewhere;
# a kerf whose parent is a kerf is rank 0's watchdog, not a rank
ranks_of() {
    ps -e -o pid=,ppid=,comm= | awk -v top="$1" '
        { parent[$1] = $2; name[$1] = $3 }
        END { for (p in name) if (name[p] == "kerf" && name[parent[p]] != "kerf") { q = p; while (q in parent && q != top && q > 1) q = parent[q]; if (q == top) print p } }' | sort -n
}

"$kerf" run drop.yaml --out ref "${frames[@]}" --quiet
check "plain run exits 0" test $? -eq 0

# --- kill one rank once frame 1003 is written ------------------------------------
mpi 3 run drop.yaml --out k "${frames[@]}" > k.log 2>&1 &
launcher=$!
for _ in $(seq 600); do [ -e k/checkpoints/drop.1003.kfc ] && break; sleep 0.1; done
pids=($(ranks_of $launcher))
check "3 ranks running when frame 1003 is written (pids: ${pids[*]})" test ${#pids[@]} -eq 3
if [ ${#pids[@]} -ne 3 ]; then
    kill -9 $launcher 2> /dev/null
    cat k.log
    exit 1
fi
# rank 0's watchdog: the kerf process whose parent is a rank (a rank's only child)
rank0_watch=$(ps -e -o pid=,ppid=,comm= | awk -v r=" ${pids[*]} " '$3 == "kerf" && index(r, " " $2 " ") { print $1 }')
check "rank 0 has a watchdog (pid ${rank0_watch:-none})" test -n "$rank0_watch"
start=$(date +%s%N)
kill -9 "${pids[1]}"
# the launcher must end by itself; after 30 s it is killed and the check fails
( sleep 30; kill -9 $launcher 2> /dev/null ) &
watchdog=$!
wait $launcher
rc=$?
took=$((($(date +%s%N) - start) / 1000000))
kill $watchdog 2> /dev/null
wait $watchdog 2> /dev/null
echo "the launcher ended $took ms after the kill, exit $rc"
check "the job stops within 10 s of a rank's kill (took $took ms), exit not 0 (got $rc)" \
    test $took -lt 10000 -a $rc -ne 0
check "no rank is left running" test -z "$(ranks_of $launcher)"
check "the log says the run stopped and how to go on" \
    grep -q "kerf: stopped: an MPI rank of this run ended, or the run was interrupted; \`kerf run --resume\` continues" k.log
check "the log says it once" test "$(grep -c "kerf: stopped" k.log)" -eq 1
# rank 0's watchdog (its own session, so no longer under the launcher) ends with it
for _ in $(seq 20); do [ -n "$rank0_watch" ] && kill -0 "$rank0_watch" 2> /dev/null || break; sleep 0.1; done
check "rank 0's watchdog ($rank0_watch) is gone" bash -c "[ -n '$rank0_watch' ] && ! kill -0 $rank0_watch 2> /dev/null"
check "the frames before the kill are written, the last one not" \
    test -e k/checkpoints/drop.1003.kfc -a ! -e k/checkpoints/drop.$last.kfc

# --- resume on 2 ranks ------------------------------------------------------------
mpi 2 run drop.yaml --out k "${frames[@]}" --resume > r.log 2>&1
check "resumed on 2 ranks: exit 0" test $? -eq 0
check "resumed after the last checkpoint written before the kill" grep -qE "resuming after frame 10(0[3-9]|1[0-5])" r.log
check "resumed run ends bit for bit on the one-rank run's last checkpoint" \
    cmp -s ref/checkpoints/drop.$last.kfc k/checkpoints/drop.$last.kfc
check "every particle file equals the one-rank run's" \
    bash -c 'for f in ref/particles/*.ply; do cmp -s $f k/${f#ref/} || exit 1; done'
check "a run that finishes says nothing of a stop" bash -c '! grep -q "kerf: stopped\|kerf: interrupted" r.log'

# --- Ctrl-C of a healthy run on 2 ranks: said as an interruption, nothing left behind --
# (as a terminal does it: the job in its own process group, SIGINT to the group;
# without job control a script's background job would ignore SIGINT)
set -m
mpi 2 run drop.yaml --out c "${frames[@]}" > c.log 2>&1 &
launcher=$!
set +m
for _ in $(seq 600); do [ -e c/checkpoints/drop.1002.kfc ] && break; sleep 0.1; done
pids=($(ranks_of $launcher))
rank0_watch=$(ps -e -o pid=,ppid=,comm= | awk -v r=" ${pids[*]} " '$3 == "kerf" && index(r, " " $2 " ") { print $1 }')
kill -INT -- -$launcher
( sleep 30; kill -9 $launcher 2> /dev/null ) &
watchdog=$!
wait $launcher
rc=$?
kill $watchdog 2> /dev/null
wait $watchdog 2> /dev/null
for _ in $(seq 20); do [ -n "$rank0_watch" ] && kill -0 "$rank0_watch" 2> /dev/null || break; sleep 0.1; done
# Hydra passes Ctrl-C on as SIGINT (rank 0 says "interrupted", or its watchdog
# the stop line when Hydra's SIGKILL came first) and waits for the ranks'
# output; Open MPI ends the ranks by SIGTERM, as when one dies, and may exit
# before their last line reaches it: there at most one line, and a true one
said_interrupted() {
    local lines
    lines=$(grep -cE "kerf: (interrupted|stopped: an MPI rank of this run ended, or the run was interrupted); \`kerf run --resume\` continues" c.log)
    [ "$(grep -cE 'kerf: (interrupted|stopped)' c.log)" -eq "$lines" ] || return 1
    if "$mpirun" --version 2>&1 | grep -q HYDRA; then [ "$lines" -eq 1 ]; else [ "$lines" -le 1 ]; fi
}
nothing_left() { [ -n "$rank0_watch" ] && [ -z "$(ranks_of $launcher)" ] && ! kill -0 "$rank0_watch" 2> /dev/null; }
check "Ctrl-C: the launcher ends, exit not 0 (got $rc)" test $rc -ne 0
check "Ctrl-C: the log says the run was interrupted, once" said_interrupted
check "Ctrl-C: no rank and no watchdog left (watchdog ${rank0_watch:-none})" nothing_left

[ $fails -eq 0 ] || { echo "--- the killed run's log:"; tail -20 k.log; echo "--- the resumed run's:"; tail -20 r.log; echo "--- the interrupted run's:"; tail -20 c.log; ls k/checkpoints k/particles; }
echo "$fails failure(s)"
test $fails -eq 0
