# Sourced by the benchmarks/gpu/ drivers: run steps in order inside a time
# budget. Needs $budget [s], $start (date +%s) and $log set by the driver.
# `left`: seconds of the budget left. `step NAME CMD...`: runs CMD with what is
# left as its limit (skipped under 40 s), its output and return code into $log.
left() { echo $(( budget - ($(date +%s) - start) )); }
step() {
  local name=$1 limit; shift
  limit=$(left)
  if [ "$limit" -lt 40 ]; then echo "== $name: skipped, $limit s left" >>"$log"; return; fi
  echo "== $name (limit $limit s): $*" >>"$log"
  local t0=$(date +%s)
  timeout "$limit" "$@" >>"$log" 2>&1
  echo "-- $name: rc $? in $(( $(date +%s) - t0 )) s" >>"$log"
}
