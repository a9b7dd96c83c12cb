# Sourced by the Slurm tests: starts a single-node Slurm on localhost (own
# munge key, own config, state and spool in the temporary folder $T; 2 CPUs,
# no cgroups, no accounting daemon), exports SLURM_CONF, and stops the
# daemons and removes $T on exit. Exits 77 (ctest SKIP) with the reason when
# a tool is missing or a daemon cannot start.
skip() { echo "SKIPPED: $*"; exit 77; }
for tool in munged slurmctld slurmd sbatch squeue sinfo sqlite3; do
  command -v "$tool" >/dev/null || skip "$tool not found (Debian packages slurm-wlm, munge, sqlite3)"
done
T=$(mktemp -d "${TMPDIR:-/tmp}/hrad-slurm.XXXXXX")
PIDS=()
cleanup() {
  [ -n "${SLURM_CONF:-}" ] && scancel --quiet --user="$(id -un)" 2>/dev/null
  for f in "$T/slurmd.pid" "$T/slurmctld.pid" "$T/munge/munged.pid"; do
    [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null
  done
  sleep 1
  rm -rf "$T"
}
trap cleanup EXIT
mkdir -p "$T/munge" "$T/state" "$T/spool" "$T/log"
chmod 700 "$T/munge"
dd if=/dev/urandom of="$T/munge/munge.key" bs=1024 count=1 2>/dev/null
chmod 600 "$T/munge/munge.key"
munged --key-file="$T/munge/munge.key" --socket="$T/munge/munge.sock" \
  --pid-file="$T/munge/munged.pid" --log-file="$T/munge/munged.log" \
  --seed-file="$T/munge/seed" -f || skip "munged does not start: $(tail -1 "$T/munge/munged.log" 2>/dev/null)"
PORT=$(( 20000 + $$ % 20000 ))
cat > "$T/slurm.conf" <<EOC
ClusterName=hradtest
SlurmctldHost=localhost
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
SlurmUser=$(id -un)
AuthType=auth/munge
AuthInfo=socket=$T/munge/munge.sock
CredType=cred/munge
StateSaveLocation=$T/state
SlurmdSpoolDir=$T/spool
SlurmctldPidFile=$T/slurmctld.pid
SlurmdPidFile=$T/slurmd.pid
SlurmctldLogFile=$T/log/slurmctld.log
SlurmdLogFile=$T/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
NodeName=localhost NodeHostname=$(hostname -s) NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=debug Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOC
export SLURM_CONF=$T/slurm.conf
slurmctld -f "$SLURM_CONF" -i || skip "slurmctld does not start: $(tail -2 "$T/log/slurmctld.log" 2>/dev/null)"
slurmd -f "$SLURM_CONF" -N localhost || skip "slurmd does not start: $(tail -2 "$T/log/slurmd.log" 2>/dev/null)"
state=""
for _ in $(seq 1 60); do
  state=$(sinfo -h -o %T 2>/dev/null)
  [ "$state" = idle ] && break
  sleep 1
done
[ "$state" = idle ] || skip "the node did not become idle in 60 s (state '$state'): $(tail -2 "$T/log/slurmd.log")"
