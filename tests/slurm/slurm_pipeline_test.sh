#!/usr/bin/env bash
# The Slurm pipeline of `hrad sweep --slurm` on a real single-node Slurm
# (own munge key, own config, state and spool in a temporary folder; 2 CPUs,
# no cgroups, no accounting daemon). An 8-point study with a full-matrix
# reference goes through hrad: references job, points array (8 tasks, 2 at
# once), merge job. The array task of the slow point #7 is cancelled
# (scancel) while its point runs: the merge job must report exactly that
# point missing and exit non-zero, and `hrad sweep --slurm --resume` must
# submit only it and complete the store. The merged store must then equal a
# local `hrad sweep` of the same study (same keys, link counts, errors,
# convergence; no duplicates, no failures), every row must name its host and
# its Slurm array job and task, and every point must have read its reference
# from the cache the references job filled (computed once per scene).
# Exit 77 (ctest SKIP) with the reason when the daemons cannot start; the
# daemons are stopped and the folder removed on exit.
# Usage: slurm_pipeline_test.sh /path/to/hrad
set -u
HRAD=${1:?usage: slurm_pipeline_test.sh HRAD_BINARY}
source "$(dirname "$0")/local_slurm.sh"

fail() { echo "FAIL: $*"; exit 1; }
waitfor() {  # waitfor SECONDS JOBIDS: until none of the jobs is queued or running
  for _ in $(seq 1 "$1"); do
    [ -z "$(squeue -h -j "$2" 2>/dev/null)" ] && return 0
    sleep 1
  done
  squeue; tail -n 5 "$T"/store.sqlite.slurm/logs/*.out; fail "jobs $2 did not finish in $1 s"
}
# Point #7 (cornell, eps 1e-5) takes seconds; the others milliseconds (bfa
# as published: with its receiver check, the default, point #7 takes minutes).
cat > "$T/study.toml" <<'EOS'
name = "slurm"
scenes = ["furnace", "cornell"]
[solver]
"hr.max_iterations" = 6
"hr.min_area" = 1e-7
"ff.vis_rays" = 64
"hr.receiver_eps" = "off"
[reference]
kind = "full-matrix"
"fm.level" = 1
[limits]
max_seconds = 300
[slurm]
max_parallel = 2
[sweep]
"oracle.eps" = [0.5, 0.2, 0.1, 1e-5]
EOS
D=$T/store.sqlite.slurm
"$HRAD" sweep "$T/study.toml" --slurm --store "$T/store.sqlite" > "$T/submit.out" 2>&1 || {
  cat "$T/submit.out"; fail "hrad sweep --slurm failed"; }
. <(sed 's/^/job_/' "$D/jobs.txt")
[ -n "$job_references" ] && [ -n "$job_points" ] && [ -n "$job_merge" ] || fail "jobs.txt incomplete: $(cat "$D/jobs.txt")"
grep -q -- '--array=0-7%2' "$D/points.sbatch" || fail "points.sbatch has no --array=0-7%2"

# Cancel array task 7 while its point runs (its shard store exists once the
# task's sweep has started; the point itself runs for seconds).
for _ in $(seq 1 120); do
  st=$(squeue -h -j "${job_points}_7" -o %T 2>/dev/null)
  [ "$st" = RUNNING ] && [ -f "$D/shards/task-7.sqlite" ] && break
  sleep 0.5
done
[ "$st" = RUNNING ] || fail "array task ${job_points}_7 never ran (state '$st')"
sleep 1
scancel "${job_points}_7" || fail "scancel ${job_points}_7 failed"
waitfor 120 "$job_references,$job_points,$job_merge"
[ -f "$D/report.txt" ] || { cat "$D"/logs/merge-*.out; fail "the merge job wrote no report"; }
grep -q '8 point(s): 7 finished, 0 failed, 1 missing' "$D/report.txt" &&
  grep -q '^missing: #7 cornell' "$D/report.txt" || { cat "$D/report.txt"; fail "report does not name #7 as the one missing point"; }
grep -q 'reference.*computed' "$D"/logs/references-*.out || fail "the references job computed nothing"

"$HRAD" sweep "$T/study.toml" --slurm --resume --store "$T/store.sqlite" > "$T/resume.out" 2>&1 || {
  cat "$T/resume.out"; fail "hrad sweep --slurm --resume failed"; }
[ "$(grep -v '^#' "$D/resume-1/points.txt")" = 7 ] || fail "resume-1/points.txt is not just point 7"
. <(sed 's/^/resume_/' "$D/resume-1/jobs.txt")
waitfor 120 "$resume_references,$resume_points,$resume_merge"
grep -q '8 point(s): 8 finished, 0 failed, 0 missing' "$D/resume-1/report.txt" || {
  cat "$D/resume-1/report.txt" "$D"/logs/*.out; fail "the store is not complete after --resume"; }
"$HRAD" sweep "$T/study.toml" --slurm --resume --store "$T/store.sqlite" | grep -q 'nothing to resubmit' ||
  fail "a second --resume found points to resubmit"

"$HRAD" --log quiet sweep "$T/study.toml" --threads 1 --cache "$T/local-cache" --store "$T/local.sqlite" >/dev/null || fail "local sweep failed"
q="SELECT key, point_index, links, printf('%.12g', l2_lum), converged FROM runs ORDER BY key"
[ "$(sqlite3 "$T/store.sqlite" "$q")" = "$(sqlite3 "$T/local.sqlite" "$q")" ] || {
  sqlite3 "$T/store.sqlite" "$q"; sqlite3 "$T/local.sqlite" "$q"; fail "merged store differs from the local sweep"; }
[ "$(sqlite3 "$T/store.sqlite" "SELECT COUNT(*), COUNT(DISTINCT key), COUNT(DISTINCT point_index) FROM runs")" = "8|8|8" ] ||
  fail "expected 8 runs of 8 distinct points"
[ "$(sqlite3 "$T/store.sqlite" "SELECT COUNT(*) FROM failures")" = 0 ] || fail "failures recorded"
prov=$(sqlite3 "$T/store.sqlite" "SELECT COUNT(*) FROM runs WHERE host <> '' AND (
  (point_index < 7 AND slurm_job_id = '$job_points' AND slurm_array_task_id = point_index) OR
  (point_index = 7 AND slurm_job_id = '$resume_points' AND slurm_array_task_id = 0))")
[ "$prov" = 8 ] || { sqlite3 "$T/store.sqlite" "SELECT point_index, host, slurm_job_id, slurm_array_task_id FROM runs";
  fail "rows without their host, Slurm array job and task (got $prov of 8)"; }
[ "$(sqlite3 "$T/store.sqlite" "SELECT COUNT(*) FROM runs WHERE json_extract(summary, '$.error.reference_cached') = 1")" = 8 ] ||
  fail "points computed their reference instead of reading the references job's cache"
echo "PASS: 8 points through hrad sweep --slurm (references $job_references, array $job_points, merge $job_merge);" \
     "task 7 cancelled, resubmitted by --resume (array $resume_points); equal to the local sweep"
