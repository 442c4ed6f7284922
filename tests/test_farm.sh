#!/usr/bin/env bash
# test_farm.sh — `kerf farm` against a real one-node Slurm on localhost
# (tools/slurm_local.sh), started for this test and stopped by its pids even
# when a check fails or the test is interrupted.
#   usage: test_farm.sh <kerf binary> <tests dir> <tools dir> wedges|resume
# wedges: a 6-frame preview shot with 2 wedges on the farm: every PNG, .vdb
#   and checkpoint exists and equals a local `kerf run --wedge` byte for byte
#   (a .vdb except its file UUID), the contact sheet exists; status and the
#   refusals (no Slurm, --ranks 2 on a shot the ranks cannot run) say what
#   they should and submit nothing; --ranks 2 on one they can run is one srun
#   step of 2 MPI ranks whose outputs equal a local one-rank run's.
# resume: the sim job is killed mid-run: its waiting tasks are cancelled,
#   nothing stays queued; a re-submit resumes from the last checkpoint,
#   skips the current frames, and ends equal to a local run; cancel touches
#   only its own jobs; a render task that fails twice is in the failures.
set -u
kerf=$1
tests=$2
tools=$3
mode=$4
if ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
    echo "skipped: slurm-wlm and munge are not installed (tools/setup.sh installs them)"
    exit 77
fi
work=$(mktemp -d /tmp/kerf_farm.XXXXXX)
cleanup() {
    # a failure shows what the controller said
    [ "${fails:-0}" -gt 0 ] && [ -f "$work/cluster/log/slurmctld.log" ] && tail -n 40 "$work/cluster/log/slurmctld.log"
    "$tools/slurm_local.sh" stop "$work/cluster"
    rm -rf "$work"
}
trap cleanup EXIT
trap 'exit 1' INT TERM
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}
# equal byte for byte; a .vdb apart from its UUID: OpenVDB writes its header as
# magic (8 bytes), file version and library major/minor (3 x 4), a has-grid-
# offsets byte, then the archive UUID as 36 ASCII characters (bytes 21-56)
same() {
    case "$1" in
    *.vdb) cmp -s <(head -c 21 "$1"; tail -c +58 "$1") <(head -c 21 "$2"; tail -c +58 "$2") ;;
    *) cmp -s "$1" "$2" ;;
    esac
}
# every output of the farm's wedge dir equals the local one; prints the count
compare_dirs() { # compare_dirs <farm dir> <local dir> <expected count>
    local n=0 bad=0
    for kind in checkpoints/*.kfc surface/*.vdb images/*.png; do
        for f in "$2"/$kind; do
            g="$1/${f#"$2"/}"
            if [ -e "$g" ] && same "$f" "$g"; then n=$((n + 1)); else bad=$((bad + 1)); echo "  differs: $g"; fi
        done
    done
    [ $bad -eq 0 ] && [ $n -eq "$3" ]
}
# wait until no job of the submission is queued or running (at most $2 s)
wait_idle() { # wait_idle <jobs.txt> <seconds>
    local ids
    ids=$(grep -v '^#' "$1" | cut -f1)
    for _ in $(seq $(($2 * 5))); do
        squeue -h -o %F | grep -qxF "$ids" || return 0
        sleep 0.2
    done
    echo "  still queued after $2 s:"; squeue
    return 1
}
cp "$tests/cli/tiny.yaml" "$work/"
cd "$work"
export OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=1
# the 2-rank sim: Open MPI asks root to say it means it
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

if [ "$mode" = wedges ]; then
    shot=(tiny.yaml --quality preview --frames 1001-1006)
    wedge=(--wedge materials.jelly.E=1e3,4e3)
    # --- no Slurm: exit 2, a clear message, nothing submitted or written ----------
    SLURM_CONF=$work/none.conf "$kerf" farm submit "${shot[@]}" "${wedge[@]}" > /dev/null 2> noslurm.txt
    rc=$?
    check "an unreachable Slurm exits 2 (got $rc)" test $rc -eq 2
    check "... says there is no configuration and nothing was submitted" \
        grep -q "no Slurm configuration at $work/none.conf.*Nothing submitted" noslurm.txt
    PATH=/nonexistent "$kerf" farm submit "${shot[@]}" > /dev/null 2> nosbatch.txt
    rc=$?
    check "no sbatch on PATH exits 2 (got $rc) and says Slurm is not installed" \
        bash -c "test $rc -eq 2 && grep -q 'Slurm is not installed' nosbatch.txt"
    check "nothing was written" test ! -e tiny
fi

# --- the cluster ------------------------------------------------------------------
eval "$("$tools/slurm_local.sh" start "$work/cluster")" || { echo "FAIL  the local Slurm did not start"; exit 1; }
echo "ok    a one-node Slurm is up ($SLURM_CONF)"

if [ "$mode" = wedges ]; then
    # --- --ranks 2: a shot the ranks cannot run is refused before anything is queued;
    # one they can run is one srun step of 2 ranks, equal to a local one-rank run
    "$kerf" farm submit "${shot[@]}" --set sim.integrator=implicit --ranks 2 > /dev/null 2> ranks.txt
    rc=$?
    check "--ranks 2 on a shot with the implicit integrator exits 2 (got $rc), names it, submits nothing" \
        bash -c "test $rc -eq 2 && grep -q 'the implicit integrator (sim.integrator: implicit) does not run over several MPI ranks' ranks.txt && test -z \"\$(squeue -h)\""
    nocontact=(--set sim.contact=off)
    "$kerf" farm submit "${shot[@]}" "${nocontact[@]}" --ranks 2 --out mpi > mpisubmit.txt 2>&1
    rc=$?
    check "--ranks 2 on a shot the ranks can run is submitted (exit $rc)" test $rc -eq 0
    wait_idle mpi/farm/jobs.txt 240
    check "the 2-rank submission ends within 4 minutes" test $? -eq 0
    check "its sim ran on 2 ranks (the frame log's balance line)" \
        bash -c "grep -qE '^frame 1006: 2 ranks: ' mpi/farm/logs/tiny_w00_sim.*.log"
    "$kerf" run "${shot[@]}" "${nocontact[@]}" --out mpilocal --quiet
    compare_dirs mpi mpilocal 18
    check "6 checkpoints, 6 .vdb and 6 PNGs from 2 ranks on the farm, each equal to a local one-rank run's" test $? -eq 0
    t0=$(date +%s.%N)
    "$kerf" farm submit "${shot[@]}" "${wedge[@]}" > submit.txt 2>&1
    rc=$?
    check "the wedges are submitted (exit $rc)" test $rc -eq 0
    check "jobs are named <shot>_w<NN>_<step>" \
        bash -c "squeue --states=all -h -o %j | sort -u | grep -c -E '^tiny_w0[12]_(sim|surface|render|guard)$|^tiny_sheet$' | grep -qx 9"
    "$kerf" farm status > status1.txt 2>&1
    check "kerf farm status lists every job of the submission" \
        test "$(grep -cE '^  tiny_(w0[12]_(sim|surface|render)|sheet) ' status1.txt)" -eq 7
    wait_idle tiny/v001/farm/jobs.txt 240
    check "the submission ends within 4 minutes" test $? -eq 0
    echo "  submit to idle: $(echo "$(date +%s.%N) - $t0" | bc) s"
    "$kerf" farm status > status2.txt 2>&1
    check "status shows every frame done" \
        test "$(grep -cE '^  tiny_w0[12]_(sim|surface|render) .* 6/6 ' status2.txt)" -eq 6
    check "no failures" test ! -s tiny/v001/farm/failures.txt
    # the same wedges run locally, by the same kerf
    "$kerf" run "${shot[@]}" "${wedge[@]}" --out local --quiet
    check "a local kerf run --wedge of the same shot exits 0" test $? -eq 0
    for w in w01 w02; do
        compare_dirs "tiny/v001/$w" "local/$w" 18
        check "$w: 6 checkpoints, 6 .vdb, 6 PNGs, each equal to the local run's" test $? -eq 0
    done
    check "the contact sheet exists (a PNG)" bash -c "file tiny/v001/contact_sheet.png | grep -q 'PNG image data'"
    check "the wedge list names both values" \
        bash -c "grep -qP '^w01\tE=1e3\t--set materials.jelly.E=1e3$' tiny/v001/wedges.txt &&
                 grep -qP '^w02\tE=4e3\t--set materials.jelly.E=4e3$' tiny/v001/wedges.txt"
    check "the sheet equals the local one" cmp -s tiny/v001/contact_sheet.png local/contact_sheet.png
    check "a log per task" test "$(ls tiny/v001/farm/logs/tiny_w0[12]_{surface,render}.*_*.log | wc -l)" -eq 24
    # everything current: a re-submit submits nothing
    "$kerf" farm submit "${shot[@]}" "${wedge[@]}" > again.txt 2>&1
    check "a re-submit of current frames submits no wedge job" \
        bash -c "test \$(grep -c 'are current; nothing to do' again.txt) -eq 2"
    # a controller that is down: exit 2, nothing submitted
    "$tools/slurm_local.sh" stop "$work/cluster"
    rm -rf tiny/v001/w02
    "$kerf" farm submit "${shot[@]}" "${wedge[@]}" > /dev/null 2> down.txt
    rc=$?
    check "a Slurm that is down exits 2 (got $rc), says so, and writes nothing" \
        bash -c "test $rc -eq 2 && grep -q 'Slurm controller does not answer.*Nothing submitted' down.txt &&
                 test ! -e tiny/v001/w02"
fi

if [ "$mode" = resume ]; then
    # a slow sim (a fixed small step, one frame a second): about a second a frame here
    shot=(tiny.yaml --quality preview --frames 1001-1006 --set frames.fps=1 --set sim.dt_fixed=0.0002)
    "$kerf" farm submit "${shot[@]}" > submit1.txt 2>&1
    check "submitted (exit $?)" test $? -eq 0
    sim=$(grep -P '\ttiny_w00_sim\t' tiny/v001/farm/jobs.txt | cut -f1)
    for _ in $(seq 600); do # kill the sim once frame 1003 is on disk
        [ -e tiny/v001/checkpoints/tiny.1003.kfc ] && break
        sleep 0.1
    done
    scancel --signal=KILL "$sim"
    wait_idle tiny/v001/farm/jobs.txt 120
    check "after the killed sim nothing of the submission stays queued" test $? -eq 0
    check "the frames after the kill were not rendered" test ! -e tiny/v001/images/tiny.1006.png
    check "the failure is reported with the sim's log" \
        grep -q "^tiny_w00_sim.*failed or cancelled.*tiny_w00_sim\.$sim\.log" tiny/v001/farm/failures.txt
    "$kerf" farm status tiny.yaml --quality preview --frames 1001-1006 --set frames.fps=1 \
        --set sim.dt_fixed=0.0002 > status.txt 2>&1
    check "status lists the failure and its log" grep -q "tiny_w00_sim.*log .*tiny_w00_sim\.$sim\.log" status.txt
    done_before=$(ls tiny/v001/images/*.png | wc -l)
    "$kerf" farm submit "${shot[@]}" > submit2.txt 2>&1
    check "re-submitted (exit $?)" test $? -eq 0
    wait_idle tiny/v001/farm/jobs.txt 240
    check "the re-submission ends" test $? -eq 0
    sim2=$(grep -P '\ttiny_w00_sim\t' tiny/v001/farm/jobs.txt | cut -f1)
    surf2=$(grep -P '\ttiny_w00_surface\t' tiny/v001/farm/jobs.txt | cut -f1)
    check "only the $((6 - done_before)) frames not current are surfaced again ($done_before were done)" \
        test "$(ls tiny/v001/farm/logs/tiny_w00_surface."$surf2"_*.log | wc -l)" -eq $((6 - done_before))
    check "the sim resumed from the last checkpoint" grep -q "resuming after frame 100[3-6]" \
        "tiny/v001/farm/logs/tiny_w00_sim.$sim2.log"
    "$kerf" run "${shot[@]}" --out local --quiet
    compare_dirs tiny/v001 local 18
    check "killed and re-submitted, every output equals an uninterrupted local run" test $? -eq 0
    # cancel: its own jobs only
    rm -rf tiny/v001/images
    touch tiny/v001/images # a file where the images go: every render fails, twice
    "$kerf" farm submit "${shot[@]}" --frames 1006 > submit3.txt 2>&1
    wait_idle tiny/v001/farm/jobs.txt 120
    render3=$(grep -P '\ttiny_w00_render\t' tiny/v001/farm/jobs.txt | cut -f1)
    check "a render task that fails is tried twice" \
        test "$(grep -c 'failed; retrying once' tiny/v001/farm/logs/tiny_w00_render."$render3"_0.log)" -eq 1
    check "... and its failure is listed with its log" \
        grep -qP '^tiny_w00_render\tframes 1006-1006\t.*/logs/tiny_w00_render\.[0-9]+_0\.log$' \
        tiny/v001/farm/failures.txt
    rm -f tiny/v001/images
    other=$(sbatch --parsable -J someone_else -o /dev/null --wrap "sleep 200")
    "$kerf" farm submit "${shot[@]}" --set sim.dt_fixed=0.0001 --set version=2 > submit4.txt 2>&1
    "$kerf" farm cancel > cancel.txt 2>&1
    check "cancel cancels its submission's jobs" grep -q "cancelled [1-9] job" cancel.txt
    for _ in $(seq 100); do [ "$(squeue -h -o %j)" = someone_else ] && break; sleep 0.1; done
    check "... and leaves the other user's job alone" test "$(squeue -h -o %j)" = someone_else
    scancel "$other"
fi

[ $fails -eq 0 ] && echo "all farm checks passed ($mode)" || echo "$fails farm check(s) failed ($mode)"
[ $fails -eq 0 ]
