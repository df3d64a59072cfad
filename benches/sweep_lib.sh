# Shared by the sweep scripts (source it): run_one "NAME|ARGS" runs `$ghm ARGS $weather`
# into $SWEEP_ROOT/NAME (through NAME.tmp, so an interrupted run leaves no summary and is
# redone), records the command's wall time in NAME/wall_s, and skips a finished NAME.
run_one() {
  local name=${1%%|*} args=${1#*|}
  local out=$SWEEP_ROOT/$name
  [ -f "$out/summary.json" ] && return 0
  rm -rf "$out.tmp"
  # shellcheck disable=SC2086
  if /usr/bin/time -f "%e" -o "/tmp/ghm-wall-$name" "$ghm" $args $weather --out "$out.tmp" > "/tmp/ghm-log-$name" 2>&1; then
    cp "/tmp/ghm-wall-$name" "$out.tmp/wall_s"
    rm -rf "$out" && mv "$out.tmp" "$out"
    echo "done $name"
  else
    echo "FAILED $name (log: /tmp/ghm-log-$name)"
  fi
}

# run_all JOBS LINE...: run_one over the lines, JOBS at a time.
run_all() {
  local jobs=$1
  shift
  export -f run_one
  export ghm weather SWEEP_ROOT
  printf '%s\n' "$@" | xargs -P "$jobs" -I{} bash -c 'run_one "$@"' _ {}
}
