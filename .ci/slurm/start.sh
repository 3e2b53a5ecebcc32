#!/usr/bin/env bash
# Starts a one-node Slurm cluster on this machine for the Slurm test (tests/slurm.rs):
# installs Debian's slurmctld, slurmd and munge, writes a minimal slurm.conf (this host, its
# CPUs, no cgroups; daemons on the loopback address, so no name resolution is needed), starts munged, slurmctld and slurmd as plain daemons (no systemd) and
# waits until `sinfo` shows the node idle. Idempotent: a running cluster is left as it is.
# Exits non-zero, saying why, when the daemons cannot start.
set -euo pipefail
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
state=/var/spool/rubscan-slurm
conf=/etc/slurm/slurm.conf
marker="# written by rubscan .ci/slurm/start.sh"
host=$(hostname -s)

fail() {
  echo "SLURM NOT STARTED: $*" >&2
  for log in "$state"/slurmctld.log "$state"/slurmd.log; do
    [ -r "$log" ] && { echo "--- tail of $log" >&2; $SUDO tail -n 20 "$log" >&2; }
  done
  exit 1
}

node_idle() {
  sinfo -h -N -n "$host" -o %t 2>/dev/null | grep -qE '^(idle|mix|alloc)'
}

if command -v sinfo >/dev/null 2>&1 && node_idle; then
  echo "slurm: node $host already up"; exit 0
fi

if ! command -v slurmctld >/dev/null 2>&1 || ! command -v slurmd >/dev/null 2>&1 \
   || ! command -v munged >/dev/null 2>&1 || ! command -v sbatch >/dev/null 2>&1; then
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null || fail "apt-get install of slurmctld slurmd slurm-client munge failed"
fi

if [ -e "$conf" ] && ! grep -qF "$marker" "$conf"; then
  fail "$conf exists and was not written by this script; not overwriting it"
fi

cpus=$(nproc)
mem_mb=$(( $(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 / 2 ))
$SUDO mkdir -p "$state/ctld" "$state/d" /etc/slurm
$SUDO tee "$conf" >/dev/null <<CONF
$marker
ClusterName=rubscan
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/d
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/slurmctld.log
SlurmdLogFile=$state/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
KillWait=5
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

# munge: the package made a key; munged runs as the munge user.
$SUDO mkdir -p /run/munge /var/log/munge /var/lib/munge
$SUDO chown munge:munge /run/munge /var/log/munge /var/lib/munge
if [ ! -s /etc/munge/munge.key ]; then
  $SUDO dd if=/dev/urandom of=/etc/munge/munge.key bs=128 count=1 status=none
  $SUDO chown munge:munge /etc/munge/munge.key && $SUDO chmod 400 /etc/munge/munge.key
fi
if ! pgrep -x munged >/dev/null; then
  if [ -z "$SUDO" ]; then runuser -u munge -- /usr/sbin/munged; else sudo -u munge /usr/sbin/munged; fi \
    || fail "munged did not start"
fi
munge -n | unmunge >/dev/null 2>&1 || fail "munge round trip (munge -n | unmunge) failed"

pgrep -x slurmctld >/dev/null || $SUDO slurmctld || fail "slurmctld did not start"
pgrep -x slurmd >/dev/null || $SUDO slurmd || fail "slurmd did not start"

for _ in $(seq 60); do
  if node_idle; then
    echo "slurm: node $host up ($cpus CPUs)"; sinfo; exit 0
  fi
  sleep 1
done
sinfo -N -l >&2 || true
fail "node $host not idle after 60 s"
