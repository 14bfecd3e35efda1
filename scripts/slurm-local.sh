#!/usr/bin/env bash
# A throw-away single-node Slurm cluster on loopback, from Debian's packages
# (slurmctld, slurmd, slurm-client, munge), without systemd, in a fresh state
# folder. It is always shut down again, also when the command fails or the
# script is interrupted: jobs cancelled, `scontrol shutdown`, munged stopped,
# nothing left running.
#
#   scripts/slurm-local.sh install                 # apt-get only the missing packages
#   scripts/slurm-local.sh run [--state DIR] [--keep] -- COMMAND [ARGS...]
#       starts the cluster, exports SLURM_CONF (and SLURM_LOCAL_STATE), runs
#       COMMAND, shuts the cluster down and exits with COMMAND's status.
#       --state DIR  use DIR (created; must be empty) instead of a mktemp -d folder
#       --keep       keep the state folder (config, logs) afterwards
#   scripts/slurm-local.sh run -- bash            # an interactive shell "on the cluster"
#
# Example, a 4-task job array on the local cluster:
#   scripts/slurm-local.sh run -- sbatch --wait --array=0-3 --output=/tmp/t-%a.out \
#       --wrap 'echo task $SLURM_ARRAY_TASK_ID of $SLURM_ARRAY_TASK_COUNT'
#
# It can also be sourced by a test that wants to time the steps itself:
#   source scripts/slurm-local.sh
#   slurm_local_start [DIR]; trap slurm_local_stop EXIT; ...; slurm_local_stop
#
# Facts it relies on (measured on Debian 12, Slurm 22.05, munge 0.5.15): as
# root with a minimal slurm.conf (one node `localhost`, no accounting,
# proctrack/linuxproc, task/none, select/cons_tres, SlurmUser=root), munged
# with its own socket and key, daemons bound to 127.0.0.1 only
# (CommunicationParameters=NoCtldInAddrAny,NoInAddrAny) on ports picked free
# at start; the node is idle about 1-2 s after start. Every wait has a
# deadline: with a dead slurmctld, `sinfo` would retry forever.
#
# Environment: SLURM_LOCAL_TIMEOUT (seconds for the node to become idle, 30),
# SLURM_LOCAL_KEEP=1 (same as --keep).

_sl_log() { echo "slurm-local: $*" >&2; }

# Pids of running munged/slurmctld/slurmd (pgrep -x takes one name at a time).
_sl_daemon_pids() {
  local n
  for n in munged slurmctld slurmd; do pgrep -x "$n" || true; done | tr '\n' ' '
}

# Install the Debian packages that are missing (idempotent; apt-get update only
# when something is missing). Kills any daemon the packages' maintainer scripts
# may have started, so that nothing is left running.
slurm_local_install() {
  local pkgs=(slurmctld slurmd slurm-client munge) missing=() p
  for p in "${pkgs[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  ((${#missing[@]})) || return 0
  if [[ $(id -u) -ne 0 ]]; then
    _sl_log "needs root to install ${missing[*]}"
    return 1
  fi
  local before
  before=" $(_sl_daemon_pids) "
  _sl_log "apt-get install ${missing[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  # Without systemd the packages' init scripts may start daemons: stop those.
  local pid
  for pid in $(_sl_daemon_pids); do
    [[ $before == *" $pid "* ]] || { _sl_log "stopping $pid started by the install"; kill "$pid" 2>/dev/null || true; }
  done
}

# Two free TCP ports on 127.0.0.1.
_sl_free_ports() {
  python3 - <<'EOF'
import socket
socks = []
for _ in range(2):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    socks.append(s)
print(" ".join(str(s.getsockname()[1]) for s in socks))
EOF
}

_sl_alive() { [[ -n ${1:-} ]] && kill -0 "$1" 2>/dev/null; }

# Wait until the pids have exited, at most $1 seconds; returns 1 if some remain.
_sl_wait_gone() {
  local deadline=$((SECONDS + $1)) pid; shift
  while ((SECONDS <= deadline)); do
    local any=0
    for pid in "$@"; do _sl_alive "$pid" && any=1; done
    ((any)) || return 0
    sleep 0.1
  done
  return 1
}

_sl_dump_logs() {
  local f
  for f in "$SLURM_LOCAL_STATE"/log/*.log; do
    [[ -f $f ]] || continue
    _sl_log "--- last lines of $f"
    tail -n 15 "$f" >&2
  done
}

# slurm_local_start [STATE_DIR]: start munged, slurmctld and slurmd; export
# SLURM_CONF and SLURM_LOCAL_STATE; return when the node is idle (or fail,
# leaving the caller to run slurm_local_stop).
slurm_local_start() {
  if [[ $(id -u) -ne 0 ]]; then
    _sl_log "must run as root (SlurmUser=root, slurmd starts jobs)"
    return 1
  fi
  slurm_local_install || return 1
  local d="${1:-}"
  if [[ -n $d ]]; then
    mkdir -p "$d"
    if [[ -n $(ls -A "$d") ]]; then _sl_log "state folder $d is not empty"; return 1; fi
    d="$(cd "$d" && pwd)"
    _SL_OWN_STATE=0
  else
    d="$(mktemp -d "${TMPDIR:-/tmp}/slurm-local.XXXXXX")"
    _SL_OWN_STATE=1
  fi
  chmod 700 "$d"
  export SLURM_LOCAL_STATE="$d"
  mkdir -p "$d/munge" "$d/ctld" "$d/slurmd" "$d/log"
  chmod 700 "$d/munge"

  # munge: own key and socket, in the foreground as our child.
  dd if=/dev/urandom of="$d/munge/munge.key" bs=1024 count=1 status=none
  chmod 400 "$d/munge/munge.key"
  local sock="$d/munge/munge.socket.2"
  munged -F --force --socket="$sock" --key-file="$d/munge/munge.key" \
    --pid-file="$d/munge/munged.pid" --log-file="$d/log/munged.log" \
    --seed-file="$d/munge/munged.seed" >>"$d/log/munged.log" 2>&1 &
  _SL_MUNGED_PID=$!
  local deadline=$((SECONDS + 10))
  until timeout 2 munge -n -S "$sock" 2>/dev/null | timeout 2 unmunge -S "$sock" >/dev/null 2>&1; do
    if ! _sl_alive "$_SL_MUNGED_PID" || ((SECONDS > deadline)); then
      _sl_log "munged did not come up"; _sl_dump_logs; return 1
    fi
    sleep 0.1
  done

  local ports ctld_port slurmd_port mem cpus
  ports="$(_sl_free_ports)" || return 1
  read -r ctld_port slurmd_port <<<"$ports"
  cpus="$(nproc)"
  # RealMemory must not exceed what slurmd finds, or the node is drained.
  mem="$(awk '/^MemTotal:/ {m = int($2 / 1024 * 0.9); print (m > 1 ? m : 1)}' /proc/meminfo)"
  cat >"$d/slurm.conf" <<EOF
# Generated by scripts/slurm-local.sh: a single-node cluster on loopback.
ClusterName=eyereplay-local
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$sock
CredType=cred/munge
CommunicationParameters=NoCtldInAddrAny,NoInAddrAny
StateSaveLocation=$d/ctld
SlurmdSpoolDir=$d/slurmd
SlurmctldPidFile=$d/slurmctld.pid
SlurmdPidFile=$d/slurmd.pid
SlurmctldLogFile=$d/log/slurmctld.log
SlurmdLogFile=$d/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
# Start jobs at once (default: batch jobs may wait up to 3 s for a scheduling pass).
SchedulerParameters=batch_sched_delay=0
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
# Finished jobs stay visible 5 s: short enough that sbatch --wait polls every 2 s.
MinJobAge=5
KillWait=5
InactiveLimit=0
SlurmctldTimeout=30
SlurmdTimeout=30
NodeName=localhost NodeAddr=127.0.0.1 NodeHostname=localhost CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="$d/slurm.conf"

  slurmctld -D -i -f "$SLURM_CONF" >>"$d/log/slurmctld.out" 2>&1 &
  _SL_CTLD_PID=$!
  slurmd -D -N localhost -f "$SLURM_CONF" >>"$d/log/slurmd.out" 2>&1 &
  _SL_SLURMD_PID=$!

  local timeout_s="${SLURM_LOCAL_TIMEOUT:-30}" state=""
  deadline=$((SECONDS + timeout_s))
  while :; do
    if ! _sl_alive "$_SL_CTLD_PID" || ! _sl_alive "$_SL_SLURMD_PID"; then
      _sl_log "a daemon exited during start"; _sl_dump_logs; return 1
    fi
    state="$(timeout 3 sinfo -h -N -n localhost -o %T 2>/dev/null || true)"
    [[ $state == idle ]] && break
    if ((SECONDS > deadline)); then
      _sl_log "node not idle after ${timeout_s}s (state '${state}')"; _sl_dump_logs; return 1
    fi
    sleep 0.2
  done
  _sl_log "cluster up: SLURM_CONF=$SLURM_CONF (ports $ctld_port/$slurmd_port, node localhost idle)"
}

# slurm_local_stop: cancel jobs, scontrol shutdown, stop munged; kill by pid
# whatever is left (our daemons, and slurmstepd processes of our cluster).
# Idempotent; always returns 0 unless something could not be stopped.
slurm_local_stop() {
  local d="${SLURM_LOCAL_STATE:-}" rc=0
  [[ -n $d ]] || return 0
  local pid grace=0
  if _sl_alive "${_SL_CTLD_PID:-}"; then
    # Cancel what is still queued or running, then shut slurmctld and slurmd down.
    timeout 5 scancel --quiet --user="$(id -un)" 2>/dev/null || true
    local deadline=$((SECONDS + 15))
    while [[ -n $(timeout 3 squeue -h -o %A 2>/dev/null) ]] && ((SECONDS <= deadline)); do sleep 0.2; done
    timeout 5 scontrol shutdown >/dev/null 2>&1 && grace=10
  fi
  # Without a working slurmctld nobody tells slurmd to stop: SIGTERM at once.
  for pid in ${_SL_CTLD_PID:-} ${_SL_SLURMD_PID:-}; do
    _sl_wait_gone "$grace" "$pid" || { kill "$pid" 2>/dev/null; _sl_wait_gone 5 "$pid" || kill -9 "$pid" 2>/dev/null; }
    wait "$pid" 2>/dev/null || true
  done
  # Job steps of this cluster (slurmstepd and what it started) carry our SLURM_CONF.
  local p
  for p in /proc/[0-9]*; do
    pid="${p#/proc/}"
    [[ $pid == "$$" || $pid == "$BASHPID" ]] && continue
    if tr '\0' '\n' 2>/dev/null <"$p/environ" | grep -qxF "SLURM_CONF=$d/slurm.conf"; then
      if [[ $(tr '\0' ' ' 2>/dev/null <"$p/cmdline") == slurmstepd* ]]; then
        _sl_log "killing leftover slurmstepd $pid"; kill -9 "$pid" 2>/dev/null || true
      fi
    fi
  done
  # Finished slurmstepd processes are reparented to init: give it a moment to
  # reap them, so that nothing, not even a zombie, is left behind.
  local deadline2=$((SECONDS + 5))
  while pgrep -x slurmstepd >/dev/null && ((SECONDS <= deadline2)); do sleep 0.1; done
  if _sl_alive "${_SL_MUNGED_PID:-}"; then
    kill "$_SL_MUNGED_PID" 2>/dev/null || true
    _sl_wait_gone 5 "$_SL_MUNGED_PID" || kill -9 "$_SL_MUNGED_PID" 2>/dev/null || true
    wait "$_SL_MUNGED_PID" 2>/dev/null || true
  fi
  for pid in ${_SL_CTLD_PID:-} ${_SL_SLURMD_PID:-} ${_SL_MUNGED_PID:-}; do
    _sl_alive "$pid" && { _sl_log "process $pid still running"; rc=1; }
  done
  if [[ ${_SL_OWN_STATE:-0} == 1 && ${SLURM_LOCAL_KEEP:-0} != 1 ]]; then
    rm -rf "$d"
  else
    _sl_log "state kept in $d"
  fi
  _SL_CTLD_PID="" _SL_SLURMD_PID="" _SL_MUNGED_PID=""
  unset SLURM_LOCAL_STATE SLURM_CONF
  _sl_log "cluster stopped"
  return "$rc"
}

# On a signal: stop the command (by its pid), then exit, which runs the EXIT trap.
_sl_interrupted() {
  if _sl_alive "${_SL_CMD_PID:-}"; then
    kill -TERM "$_SL_CMD_PID" 2>/dev/null || true
    _sl_wait_gone 5 "$_SL_CMD_PID" || kill -KILL "$_SL_CMD_PID" 2>/dev/null || true
  fi
  exit "$1"
}

_sl_main() {
  set -uo pipefail
  local cmd="${1:-}"; shift || true
  case "$cmd" in
    install) slurm_local_install ;;
    run)
      local state=""
      while (($#)); do
        case "$1" in
          --state) state="$2"; shift 2 ;;
          --keep) export SLURM_LOCAL_KEEP=1; shift ;;
          --) shift; break ;;
          *) _sl_log "unknown option $1"; return 2 ;;
        esac
      done
      if ((!$#)); then _sl_log "run: no command given (run [--state DIR] [--keep] -- COMMAND...)"; return 2; fi
      _SL_CMD_PID=""
      trap 'slurm_local_stop' EXIT
      trap '_sl_interrupted 130' INT
      trap '_sl_interrupted 143' TERM
      trap '_sl_interrupted 129' HUP
      if ! slurm_local_start "$state"; then
        SLURM_LOCAL_KEEP="${SLURM_LOCAL_KEEP:-0}"
        return 1
      fi
      # In the background + wait, so that a signal to this script is handled at
      # once (bash runs traps only between commands); stdin passed on explicitly.
      local status=0
      if { true <&0; } 2>/dev/null; then "$@" 0<&0 & else "$@" </dev/null & fi
      _SL_CMD_PID=$!
      wait "$_SL_CMD_PID" || status=$?
      _SL_CMD_PID=""
      return "$status"
      ;;
    *)
      sed -n '2,22p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//' >&2
      [[ $cmd == -h || $cmd == --help || $cmd == help ]] && return 0
      return 2
      ;;
  esac
}

if [[ ${BASH_SOURCE[0]} == "$0" ]]; then
  _sl_main "$@"
  exit $?
fi
