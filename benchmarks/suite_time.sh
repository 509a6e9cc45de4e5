#!/bin/bash
# Times the default test suite at two commits, one after the other, each in a
# clean worktree beside the checkout (so ../shared resolves as in the
# checkout), with a fresh JAX cache per suite (tests/conftest.py) and the
# checkout's .venv. Run it on an otherwise idle machine.
#
#   bash benchmarks/suite_time.sh BASE_REV HEAD_REV OUT_DIR
#
# OUT_DIR/summary: start/end time, load average, pytest's last line and
# /usr/bin/time's real/user seconds per suite; OUT_DIR/{base,head}/: pytest's
# log and the per-test JSON lines of $BLE_LATEX_TEST_COMPILES (compiles,
# compile seconds, wall seconds). Issue 43's "no slower" pairs (2026-11-28,
# docs/layout.md) were measured this way.
set -u
[ $# -eq 3 ] || { echo "usage: $0 BASE_REV HEAD_REV OUT_DIR" >&2; exit 2; }
repo=$(git rev-parse --show-toplevel) || exit 2
out=$(mkdir -p "$3" && cd "$3" && pwd) || exit 1
for pair in "base:$1" "head:$2"; do
  name=${pair%%:*}; rev=${pair#*:}
  wt=$(dirname "$repo")/suite_time_$name
  git -C "$repo" worktree remove --force "$wt" 2>/dev/null
  git -C "$repo" worktree add -q --detach "$wt" "$rev" || exit 1
  rm -rf "$out/$name"; mkdir -p "$out/$name"
  echo "$name $rev start $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)" >> "$out/summary"
  ( cd "$wt" && unset JAX_COMPILATION_CACHE_DIR &&
    BLE_LATEX_TEST_COMPILES="$out/$name" /usr/bin/time -p \
      "$repo/.venv/bin/python" -m pytest --durations=40 -q \
      > "$out/$name/log" 2> "$out/$name/time" )
  echo "$name $rev end $(date -u +%FT%TZ) load $(cut -d' ' -f1-3 /proc/loadavg)" \
       "$(tail -1 "$out/$name/log")" \
       "$(grep -E '^(real|user)' "$out/$name/time" | tr '\n' ' ')" >> "$out/summary"
  git -C "$repo" worktree remove --force "$wt"
done
