#!/usr/bin/env bash
# A one-node Slurm cluster on localhost (munged, slurmctld, slurmd) for the tests, in a folder of
# its own. Source it, then:
#   cluster_prerequisites || exit 77   # skipped where Slurm/munge are missing or not root
#   cluster_start DIR                  # daemons in the foreground, children of this shell
#   ... sbatch / srun (SLURM_CONF is exported) ...
#   cluster_stop                       # also on EXIT: daemons stopped and reaped
# Slurm and munge come from Debian (slurm-wlm, munge); tools/install-deps.sh installs them.

cluster_prerequisites() {
  local missing=()
  for tool in munged slurmctld slurmd sbatch sinfo scontrol; do command -v "$tool" >/dev/null || missing+=("$tool"); done
  if [[ ${#missing[@]} -gt 0 ]]; then
    echo "SKIP: no Slurm here (missing: ${missing[*]}; Debian: slurm-wlm munge)"
    return 1
  fi
  if [[ $(id -u) != 0 ]]; then
    echo "SKIP: the test cluster's daemons run as root"
    return 1
  fi
}

cluster_pids=()

cluster_stop() {
  local pid
  for pid in "${cluster_pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${cluster_pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
  done
  cluster_pids=()
}

# A free TCP port on localhost (the test may run beside another cluster or a real slurmd).
cluster_free_port() {
  /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# The log lines a failure needs.
cluster_logs() {
  local f
  for f in "$cluster_dir"/munged.log "$cluster_dir"/slurmctld.log "$cluster_dir"/slurmd.log; do
    [[ -f $f ]] && { echo "--- $f"; tail -n 20 "$f"; }
  done
}

cluster_start() {
  cluster_dir=$(realpath -m "$1")
  mkdir -p "$cluster_dir"/{munge,state,spool}
  chmod 755 "$cluster_dir/munge"
  trap cluster_stop EXIT

  # munge: a key of our own and a socket in our folder (--force: run as root, a /tmp path).
  dd if=/dev/urandom of="$cluster_dir/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$cluster_dir/munge/munge.key"
  setsid munged --foreground --force --key-file="$cluster_dir/munge/munge.key" \
    --socket="$cluster_dir/munge/munge.socket" --pid-file="$cluster_dir/munge/munged.pid" \
    --seed-file="$cluster_dir/munge/munged.seed" --log-file="$cluster_dir/munged.log" >/dev/null 2>&1 &
  cluster_pids+=($!)
  for _ in $(seq 100); do [[ -S $cluster_dir/munge/munge.socket ]] && break; sleep 0.1; done
  [[ -S $cluster_dir/munge/munge.socket ]] || { echo "munged did not start"; cluster_logs; return 1; }

  local host cpus memory
  host=$(hostname -s)
  cpus=${CLUSTER_CPUS:-4}   # more than the machine's 2 cores is fine: config_overrides, tasks share them
  memory=$(( $(awk '/MemTotal/ {print int($2 / 1024)}' /proc/meminfo) / 2 ))
  sed -e "s|@DIR@|$cluster_dir|g" -e "s|@HOST@|$host|g" -e "s|@CPUS@|$cpus|g" -e "s|@MEMORY@|$memory|g" \
      -e "s|@MEM_PER_CPU@|$(( memory / cpus ))|g" \
      -e "s|@CTLD_PORT@|$(cluster_free_port)|g" -e "s|@SLURMD_PORT@|$(cluster_free_port)|g" \
      "$(dirname "${BASH_SOURCE[0]}")/slurm.conf.in" > "$cluster_dir/slurm.conf"
  export SLURM_CONF=$cluster_dir/slurm.conf

  setsid slurmctld -D -i -f "$SLURM_CONF" >"$cluster_dir/slurmctld.out" 2>&1 &
  cluster_pids+=($!)
  setsid slurmd -D -f "$SLURM_CONF" >"$cluster_dir/slurmd.out" 2>&1 &
  cluster_pids+=($!)
  local state=""
  for _ in $(seq 300); do
    state=$(sinfo -h -o %t 2>/dev/null || true)
    [[ $state == idle ]] && return 0
    sleep 0.1
  done
  echo "the test cluster did not come up (node state: '${state:-none}')"
  cat "$cluster_dir"/slurmctld.out "$cluster_dir"/slurmd.out 2>/dev/null | tail -n 20
  cluster_logs
  return 1
}
