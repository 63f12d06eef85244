#!/bin/sh
# Volume run of the libFuzzer targets: each for 10 M executions (by default),
# printing executions and findings. CI runs each
# target briefly from the seed corpus (ctest -L fuzz); this is the long run.
#
# Usage: tests/fuzz/run_volume.sh [EXECUTIONS [TARGET...]]
#   EXECUTIONS  libFuzzer -runs per target (default 10000000)
#   TARGET      frame_decoder, protocol_validator, client_session (default: all, one after another)
# Environment:
#   FUZZ_BUILD_DIR  where the targets are (default: build/tests/fuzz under the repository)
#   FUZZ_WORK_DIR   scratch directory (default: a new mktemp -d; /dev/shm makes the
#                   client_session's run recordings cheaper); the committed corpus
#                   is copied there, new inputs and findings stay there
#   FUZZ_NICE       nice increment (default 10: the machine stays usable)
#   FUZZ_TIMEOUT    seconds per input before libFuzzer calls it a timeout (default 10;
#                   wall-clock: at nice 19 beside other work raise it, and re-run any
#                   timeout- artifact alone to tell a hang from CPU starvation)
#   FUZZ_MAX_SECONDS  stop a target after this long even if short of EXECUTIONS
#                   (default 0: no limit); the shortfall is then reported as a failure
#   FUZZ_CORPUS     a directory of inputs to start from besides the committed seed
#                   corpus, e.g. an earlier volume run's <work>/<target>/corpus: a
#                   campaign continued where the last one stopped
#   FUZZ_JOBS       processes per target (default 1): each runs EXECUTIONS/JOBS from the
#                   same corpus directory (libFuzzer reloads it, so each sees the
#                   others' new inputs); executions are summed over the processes
#
# Prints per target: executions, exec/s, wall seconds, findings (crash-,
# leak-, timeout-, oom- files); exits 1 when any target has a finding, did not
# finish cleanly, or ran fewer than EXECUTIONS.
set -u
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
runs=${1:-10000000}
[ $# -gt 0 ] && shift
targets=${*:-frame_decoder protocol_validator client_session}
build=${FUZZ_BUILD_DIR:-$repo/build/tests/fuzz}
work=${FUZZ_WORK_DIR:-$(mktemp -d "${TMPDIR:-/tmp}/tribo-fuzz-volume.XXXXXX")}
nice_by=${FUZZ_NICE:-10}
timeout_s=${FUZZ_TIMEOUT:-10}
max_s=${FUZZ_MAX_SECONDS:-0}
jobs=${FUZZ_JOBS:-1}

status=0
printf '%-20s %12s %10s %8s %9s  %s\n' target executions exec/s wall_s findings log
for t in $targets; do
  bin=$build/$t
  if [ ! -x "$bin" ]; then
    echo "$t: no fuzz target at $bin (build it: cmake --build build --target ${t}_build)" >&2
    status=1
    continue
  fi
  dir=$work/$t
  rm -rf "$dir"
  mkdir -p "$dir/corpus" "$dir/artifacts"
  cp "$here/corpus/$t/"* "$dir/corpus/"
  if [ -n "${FUZZ_CORPUS:-}" ]; then cp "$FUZZ_CORPUS/"* "$dir/corpus/"; fi
  start=$(date +%s)
  # The harness runs in its own directory, its temporary files (client_session's
  # data directory) under it: whatever it writes stays in the scratch dir.
  per_job=$(( (runs + jobs - 1) / jobs ))
  pids=
  j=1
  while [ "$j" -le "$jobs" ]; do
    (cd "$dir" && TMPDIR="$dir" exec nice -n "$nice_by" "$bin" corpus -runs="$per_job" -print_final_stats=1 \
        -timeout="$timeout_s" -max_total_time="$max_s" -rss_limit_mb=2048 -artifact_prefix="$dir/artifacts/" \
        >"$dir/log.$j" 2>&1) &
    pids="$pids $!"
    j=$((j + 1))
  done
  rc=0
  for p in $pids; do wait "$p" || rc=$?; done
  wall=$(( $(date +%s) - start ))
  executed=0
  rate=
  j=1
  while [ "$j" -le "$jobs" ]; do
    n=$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/log.$j" | tail -n 1)
    r=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$dir/log.$j" | tail -n 1)
    if [ -z "$n" ]; then executed=; break; fi
    executed=$((executed + n))
    rate="${rate:+$rate+}$r"
    j=$((j + 1))
  done
  cat "$dir"/log.* >"$dir/log"
  findings=$(find "$dir/artifacts" -type f \( -name 'crash-*' -o -name 'leak-*' -o -name 'timeout-*' \
      -o -name 'oom-*' \) | wc -l)
  printf '%-20s %12s %10s %8s %9s  %s\n' "$t" "${executed:-?}" "${rate:-?}" "$wall" "$findings" "$dir/log"
  if [ "$findings" -ne 0 ] || [ "$rc" -ne 0 ] || [ -z "$executed" ] || [ "$executed" -lt "$runs" ]; then
    echo "$t: FAILED (exit $rc, $findings finding(s), ${executed:-no} executions of $runs): see $dir/log and $dir/artifacts/" >&2
    status=1
  fi
done
exit $status
