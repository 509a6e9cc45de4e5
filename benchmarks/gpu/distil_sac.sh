#!/bin/bash
# Distil, then fine-tune with SAC (issue 47, item 1), on the corrected wind
# column by default: for each seed (side by side on the one GPU),
#   1. DAgger from `latex_mpc` (benchmarks/gpu/dagger.sh's settings) for
#      DAGGER_S seconds;
#   2. the jitted SAC trainer started from that seed's best validated student
#      (`sac_trainer_config.init_policy`), its critics trained alone for the
#      first WARMUP updates (`sac_trainer_config.actor_warmup_updates`, default
#      17 280 = 10 rounds of 216 strides x 8 updates), a policy snapshot
#      flown on 100 `latex_validation` seeds every 5 rounds, until the budget
#      is spent.
# OBS_GIN (default gin_configs/latex_wind_memory.gin; '' for the paper's
# observation) is parsed by both steps, so the student and SAC observe alike.
# DAGGER_BINDINGS and SAC_BINDINGS (gin lines separated by ';') come after the
# settings here and override them; VALIDATION (default 100) is the SAC
# snapshots' validation seeds (a dry run on a CPU: tiny values of all three).
# OUT/seed_S.tar holds dagger/{run.json,summary.json,best_policy.msgpack} and
# sac/{run.json,validation.jsonl,chosen_policy.msgpack} (the snapshot with the
# best validation among those <= 5 % out of resources, chosen as
# benchmarks/sac_seeds.py chooses); OUT/log.txt the steps. Fly a chosen
# policy on this machine's CPU afterwards:
#   ble-latex-eval --agent=sac_pretrained --suite=latex_small --gin_file=OBS_GIN \
#     --gin_bindings="SACPretrainedAgent.policy_path='seed_S/sac/chosen_policy.msgpack'"
# Needs gpu_site/ (benchmarks/gpu/prepare_site.sh). Usage, in the checkout:
#   bash benchmarks/gpu/distil_sac.sh OUT BUDGET_S [SEEDS] [DAGGER_S]
set -u
out=${1:?usage: distil_sac.sh OUT BUDGET_S [SEEDS] [DAGGER_S]}
budget=${2:-540}
seeds=${3:-0,1,2}
dagger_s=${4:-$(( budget * 2 / 5 ))}
warmup=${WARMUP:-17280}
obs_gin=${OBS_GIN-gin_configs/latex_wind_memory.gin}
start=$(date +%s)
export PYTHONPATH=$PWD:$PWD/gpu_site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
export XLA_PYTHON_CLIENT_PREALLOCATE=false
py=${PYTHON:-python3}
runs=${RUNS:-/tmp/distil_sac_runs}
log=$out/log.txt
mkdir -p "$out" "$runs"
. "$(dirname "$0")/budget.sh"
{ date -u; nvidia-smi -L; $py -c 'import jax; print("jax", jax.__version__, jax.devices())'; uptime; } >>"$log" 2>&1
gin=()
[ -n "$obs_gin" ] && gin=(--gin_file="$obs_gin")
dagger_extra=() sac_extra=()
IFS=';' read -ra items <<<"${DAGGER_BINDINGS:-}"
for b in "${items[@]}"; do [ -n "$b" ] && dagger_extra+=(--gin_bindings="$b"); done
IFS=';' read -ra items <<<"${SAC_BINDINGS:-}"
for b in "${items[@]}"; do [ -n "$b" ] && sac_extra+=(--gin_bindings="$b"); done
IFS=, read -ra list <<<"$seeds"
[ "${#list[@]}" -le 3 ] || { echo "distil_sac.sh: at most 3 seeds (8 files come back)" >&2; exit 2; }
echo "== seeds ${list[*]}: DAgger ${dagger_s} s, then SAC (warm-up $warmup updates) to ${budget} s; ${gin[*]}" >>"$log"
for s in "${list[@]}"; do
  ( d="$runs/seed_$s"
    timeout "$dagger_s" $py benchmarks/train_dagger.py --base_dir="$d/dagger" \
      --seed="$s" --rounds=200 "${gin[@]}" \
      --gin_bindings='dagger_config.num_balloons = 256' \
      --gin_bindings='dagger_config.validation_seeds = 100' \
      --gin_bindings='dagger_config.fit_steps = 2000' \
      --gin_bindings='dagger_config.batch_size = 1024' \
      --gin_bindings='dagger_config.dataset_capacity = 1000000' \
      "${dagger_extra[@]}" >"$out/seed_$s.log" 2>&1
    echo "-- dagger seed $s: rc $?" >>"$log"
    [ -f "$d/dagger/best_policy.msgpack" ] || exit 1
    limit=$(( $(left) - 40 ))  # Leaves time to choose and pack.
    timeout "$limit" $py -m ble_latex.cli.train --trainer=jax --base_dir="$d/sac" \
      --seeds="$s" --num_iterations=100000 --policy_snapshot_period=5 \
      --checkpoint_period=10 --collectors=episodes "${gin[@]}" \
      --gin_bindings="sac_trainer_config.init_policy = '$d/dagger/best_policy.msgpack'" \
      --gin_bindings="sac_trainer_config.actor_warmup_updates = $warmup" \
      --validation_episodes="${VALIDATION:-100}" "${sac_extra[@]}" \
      >>"$out/seed_$s.log" 2>&1
    echo "-- sac seed $s: rc $?" >>"$log" ) &
done
wait
for s in "${list[@]}"; do
  d="$runs/seed_$s"
  $py - "$d/sac/seed_$s" >>"$log" 2>&1 <<'EOF'
import os, shutil, sys
from ble_latex import run_files
from ble_latex.run import records, selection
run = sys.argv[1]
validation = records.load_validation(os.path.join(run, 'validation.jsonl'))
chosen = selection.choose_snapshot(validation, 5.0, None, None)
print(run, 'chosen', chosen)
if chosen:
  shutil.copy(run_files.policy_snapshot_path(run, chosen['iteration']),
              run_files.chosen_policy_path(run))
EOF
  mkdir -p "$runs/pack/seed_$s/dagger" "$runs/pack/seed_$s/sac"
  cp "$d/dagger"/{run.json,summary.json,best_policy.msgpack} "$runs/pack/seed_$s/dagger/" 2>>"$log"
  cp "$d/sac/seed_$s"/{run.json,validation.jsonl,chosen_policy.msgpack} "$runs/pack/seed_$s/sac/" 2>>"$log"
  tar cf "$out/seed_$s.tar" -C "$runs/pack" "seed_$s" 2>>"$log"
done
echo "== done in $(( $(date +%s) - start )) s" >>"$log"
