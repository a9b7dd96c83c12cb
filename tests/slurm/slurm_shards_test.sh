#!/usr/bin/env bash
# A real single-node Slurm cluster on localhost (own munge key, own config,
# state and spool in a temporary folder; 2 CPUs, no cgroups, no accounting
# daemon) runs a 4-point study as a job array of `hrad sweep --shard i/4`,
# one shard store per task, then a merge job (afterany on the array). The
# merged store must equal a local `hrad sweep` of the same study (same keys,
# link counts and errors, no duplicates) and every row must name its Slurm
# array job and task. Exit 77 (ctest SKIP) with the reason when the daemons
# cannot start; the daemons are stopped and the folder removed on exit.
# Usage: slurm_shards_test.sh /path/to/hrad
set -u
HRAD=${1:?usage: slurm_shards_test.sh HRAD_BINARY}
source "$(dirname "$0")/local_slurm.sh"
mkdir -p "$T/shards"

fail() { echo "FAIL: $*"; exit 1; }
cat > "$T/study.toml" <<'EOS'
name = "slurm"
scenes = ["furnace"]
[solver]
"hr.max_iterations" = 4
[sweep]
"oracle.eps" = [0.5, 0.2, 0.1, 0.05]
EOS
cat > "$T/points.sbatch" <<EOS
#!/bin/bash
#SBATCH --job-name=hrad-points
#SBATCH --array=0-3%2
#SBATCH --cpus-per-task=1
#SBATCH --output=$T/log/points-%A_%a.out
exec "$HRAD" sweep "$T/study.toml" --threads 1 --shard "\$SLURM_ARRAY_TASK_ID/4" --store "$T/shards/shard-\$SLURM_ARRAY_TASK_ID.sqlite"
EOS
cat > "$T/merge.sbatch" <<EOS
#!/bin/bash
#SBATCH --job-name=hrad-merge
#SBATCH --output=$T/log/merge-%j.out
exec "$HRAD" results merge "$T/merged.sqlite" $T/shards/shard-*.sqlite
EOS
arr=$(sbatch --parsable "$T/points.sbatch") || fail "sbatch of the array failed"
merge=$(sbatch --parsable --dependency=afterany:"$arr" "$T/merge.sbatch") || fail "sbatch of the merge failed"
for _ in $(seq 1 300); do
  [ -z "$(squeue -h -j "$arr,$merge" 2>/dev/null)" ] && break
  sleep 1
done
[ -z "$(squeue -h -j "$arr,$merge" 2>/dev/null)" ] && [ -f "$T/merged.sqlite" ] || {
  squeue; cat "$T"/log/*.out; fail "the pipeline did not finish in 300 s"; }

"$HRAD" --log quiet sweep "$T/study.toml" --threads 1 --store "$T/local.sqlite" >/dev/null || fail "local sweep failed"
q="SELECT key, links, printf('%.12g', l2_lum), converged FROM runs ORDER BY key"
[ "$(sqlite3 "$T/merged.sqlite" "$q")" = "$(sqlite3 "$T/local.sqlite" "$q")" ] || {
  sqlite3 "$T/merged.sqlite" "$q"; sqlite3 "$T/local.sqlite" "$q"; fail "merged store differs from the local sweep"; }
[ "$(sqlite3 "$T/merged.sqlite" "SELECT COUNT(*), COUNT(DISTINCT point_index) FROM runs")" = "4|4" ] ||
  fail "expected 4 runs of 4 distinct points"
[ "$(sqlite3 "$T/merged.sqlite" "SELECT COUNT(*) FROM failures")" = 0 ] || fail "failures recorded"
prov=$(sqlite3 "$T/merged.sqlite" "SELECT COUNT(*) FROM runs WHERE slurm_job_id = '$arr' AND slurm_array_task_id = point_index AND host <> ''")
[ "$prov" = 4 ] || fail "rows without their Slurm array job $arr and task (got $prov of 4)"
[ -z "$(sqlite3 "$T/local.sqlite" "SELECT slurm_job_id FROM runs WHERE slurm_job_id IS NOT NULL")" ] ||
  fail "local rows claim a Slurm job"
echo "PASS: 4 points through Slurm array job $arr, merged by job $merge, equal to the local sweep"
