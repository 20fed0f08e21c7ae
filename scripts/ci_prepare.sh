#!/usr/bin/env bash
# The parts of `.ci/run` that the tests do not wait for, run in the background while the tests
# build and run, so that a fresh machine's downloads, clippy and the release build of the wheel
# (about 24 CPU-minutes) use the CPU the tests leave idle (servers starting, fsyncs, kills,
# sleeps) instead of adding their own minutes to CI's:
#   tools  — Chromium (apt) and the pinned venvs and npm packages of the checks (scripts/lib/);
#   clippy — `cargo clippy --workspace --all-targets -- -D warnings`, in target/clippy (a target
#            directory of its own: two cargo commands on one directory wait for each other);
#   wheel  — scripts/wheel.sh, the one release build (install_check.sh's own call of it then
#            finds everything built).
# They run at the lowest CPU and I/O priority (nice 19, ionice idle), each in a session of its
# own (so `stop` can end its whole process group), so the tests keep the cores they ask for;
# logs and exit codes in target/ci-prepare/. A session of its own is also a scheduler autogroup
# of its own where the kernel groups by session (`/proc/sys/kernel/sched_autogroup_enabled`,
# on for Debian's kernels and on CI's machine): there a process's nice orders it only within its
# group, and each group gets an equal share, so three nice-19 jobs took two thirds of the CPU
# from the tests' build (seen: CI at 68 min). Each job therefore sets its group's nice to 19 too.
#
#   scripts/ci_prepare.sh start          # both jobs in the background; returns at once
#   scripts/ci_prepare.sh pause|resume   # stop and continue them (while a test measures latency)
#   scripts/ci_prepare.sh wait JOB       # until JOB (tools, clippy, wheel) ends; its log if it failed
#   scripts/ci_prepare.sh stop           # ends whatever still runs (.ci/run's EXIT trap)
set -euo pipefail
cd "$(dirname "$0")/.."
dir="${CARGO_TARGET_DIR:-target}/ci-prepare"
JOBS=(tools clippy wheel)

# One job's work, run by `start` in its own session (so its process group id is its pid).
run_job() {
  # This session's autogroup at the lowest weight (see the header); where autogroups are off or
  # the file is missing, the process's own nice 19 already does it.
  echo 19 >/proc/self/autogroup 2>/dev/null || true
  echo $$ >"$dir/$1.pgid"
  date +%s >"$dir/$1.started"
  case "$1" in
    tools)
      source scripts/lib/chromium.sh
      (source scripts/lib/nats_server.sh)
      (source scripts/lib/python_sdk.sh)
      (source scripts/lib/mcap_tools.sh)
      (source scripts/lib/conformance_tools.sh)
      (source scripts/lib/mcpb_tools.sh)
      ;;
    clippy)
      # The core's purity bans live in crates/physics-core/clippy.toml and bind that crate's
      # code wherever it is compiled: every package and target (tests, benches).
      cargo clippy --workspace --all-targets --locked --target-dir "${CARGO_TARGET_DIR:-target}/clippy" -- -D warnings
      ;;
    wheel)
      scripts/wheel.sh
      ;;
    *) echo "ci_prepare: no job $1" >&2; return 2 ;;
  esac
}

# Sends SIGNAL to JOB if it still runs.
signal_one() {
  [[ -f "$dir/$2.pgid" && ! -f "$dir/$2.rc" ]] || return 0
  kill "-$1" -- "-$(cat "$dir/$2.pgid")" 2>/dev/null || true
}

# Sends SIGNAL to every job still running.
signal_jobs() {
  local job
  for job in "${JOBS[@]}"; do signal_one "$1" "$job"; done
}

case "${1:?start, pause, resume, wait JOB or stop}" in
  start)
    rm -rf "$dir"
    mkdir -p "$dir"
    for job in "${JOBS[@]}"; do
      (
        status=0
        setsid nice -n 19 ionice -c 3 -t "$0" run "$job" >"$dir/$job.log" 2>&1 || status=$?
        date +%s >"$dir/$job.ended"
        echo "$status" >"$dir/$job.rc"
      ) </dev/null &
    done
    ;;
  run)
    run_job "${2:?a job}"
    ;;
  pause) signal_jobs STOP ;;
  resume) signal_jobs CONT ;;
  wait)
    job="${2:?tools, clippy or wheel}"
    [[ -f "$dir/$job.log" ]] || { echo "ci_prepare: $job was not started" >&2; exit 2; }
    asked=$(date +%s)
    # While .ci/run waits for this job, the others stop, so that it gets all the CPU the run
    # leaves (at the end the wheel and clippy split it evenly, and only the wheel is waited for).
    signal_jobs STOP
    signal_one CONT "$job"
    while [[ ! -f "$dir/$job.rc" ]]; do sleep 1; done
    signal_jobs CONT
    ended=$(cat "$dir/$job.ended")
    started=$(cat "$dir/$job.started" 2>/dev/null || echo "$ended")
    if [[ "$(cat "$dir/$job.rc")" != 0 ]]; then
      cat "$dir/$job.log" >&2
      echo "ci_prepare: $job failed (exit $(cat "$dir/$job.rc"); its log is above)" >&2
      exit 1
    fi
    if ((ended > asked)); then
      echo "ci_prepare: $job took $((ended - started)) s in the background; waited $((ended - asked)) s for it" >&2
    else
      echo "ci_prepare: $job took $((ended - started)) s in the background, ready $((asked - ended)) s before it was needed" >&2
    fi
    ;;
  stop)
    signal_jobs CONT
    signal_jobs TERM
    ;;
  *) echo "ci_prepare: start, pause, resume, wait JOB or stop" >&2; exit 2 ;;
esac
