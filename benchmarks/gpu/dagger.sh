#!/bin/bash
# DAgger at a GPU's scale (issue 47): the forecast planner `latex_mpc` labels
# every stride of NUM_BALLOONS flights per round (`ble_latex.run.dagger`,
# benchmarks/train_dagger.py), where a 2-core CPU labels 4 flights in ~8 min.
# The seeds train side by side, one process each on the one GPU
# (XLA_PYTHON_CLIENT_PREALLOCATE=false, so they share its memory; their
# compiles overlap on the host's cores), until BUDGET_S is spent: a seed's
# rounds run until then (the cut round is lost, the finished ones kept: a
# run resumes from its newest round, and the same command with a run
# directory carried back continues it).
# Settings: 256 balloons a round, 100 validation seeds of latex_validation,
# 2 000 Adam steps on minibatches of 1 024 rows, an aggregate of up to
# 1 000 000 rows; DAGGER_BINDINGS (gin lines separated by ';') come after
# these and override them. DAGGER_GIN_FILES (paths separated by ',') are
# parsed first, in order: the realistic task (issue 63) with the reserves
# planner with priced resources (benchmarks/records/planners/realistic_task/DECLARATION_costs.md) as the teacher is
#   DAGGER_GIN_FILES=gin_configs/latex_realistic.gin,gin_configs/latex_realistic_task.gin,gin_configs/latex_sun_observation.gin \
#   DAGGER_BINDINGS='LatexMpcAgent.resource_buffer_kg = 0.6;LatexMpcAgent.sand_cost = 2.0;LatexMpcAgent.helium_cost = 2.0' \
#   bash benchmarks/gpu/dagger.sh OUT 540
# The run directories sit in $RUNS (default /tmp/dagger_runs): the aggregate in
# a checkpoint is too big to come back. OUT/seed_S.tar holds seed_S/run.json,
# seed_S/summary.json (per-round validation, wall times) and
# seed_S/best_policy.msgpack (one file a seed, under the 16 MB a file may
# bring back: a 3 x 512 student's three files together were over it), beside
# OUT/seed_S.log and OUT/log.txt (at most 8 files come back: 3 seeds at most);
# fly the students on this machine's CPU afterwards:
#   ble-latex-eval --agent=sac_pretrained --suite=latex_small \
#     --gin_bindings="SACPretrainedAgent.policy_path='seed_S/best_policy.msgpack'"
# Needs what benchmarks/gpu/prepare_site.sh builds (gpu_site/). Usage, in the
# checkout: bash benchmarks/gpu/dagger.sh OUT BUDGET_S [SEEDS] [NUM_BALLOONS]
set -u
out=${1:?usage: dagger.sh OUT BUDGET_S [SEEDS] [NUM_BALLOONS]}
budget=${2:-540}
seeds=${3:-0,1,2}
balloons=${4:-256}
start=$(date +%s)
export PYTHONPATH=$PWD:$PWD/gpu_site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
export XLA_PYTHON_CLIENT_PREALLOCATE=false
py=${PYTHON:-python3}
runs=${RUNS:-/tmp/dagger_runs}
log=$out/log.txt
# Usage errors first, before anything is written or started.
IFS=, read -ra list <<<"$seeds"
[ "${#list[@]}" -le 3 ] || { echo "dagger.sh: at most 3 seeds (8 files come back)" >&2; exit 2; }
IFS=, read -ra gin_files <<<"${DAGGER_GIN_FILES:-}"
files=()
for g in "${gin_files[@]}"; do
  [ -f "$g" ] || { echo "dagger.sh: DAGGER_GIN_FILES: no file $g" >&2; exit 2; }
  files+=(--gin_file="$g")
done
mkdir -p "$out" "$runs"
. "$(dirname "$0")/budget.sh"
{ date -u; nvidia-smi -L; $py -c 'import jax, flax, optax; print("jax", jax.__version__, "flax", flax.__version__, "optax", optax.__version__, jax.devices())'; uptime; } >>"$log" 2>&1
bindings=(--gin_bindings="dagger_config.num_balloons = $balloons"
          --gin_bindings='dagger_config.validation_seeds = 100'
          --gin_bindings='dagger_config.fit_steps = 2000'
          --gin_bindings='dagger_config.batch_size = 1024'
          --gin_bindings='dagger_config.dataset_capacity = 1000000')
IFS=';' read -ra extra <<<"${DAGGER_BINDINGS:-}"
for b in "${extra[@]}"; do [ -n "$b" ] && bindings+=(--gin_bindings="$b"); done
limit=$(( $(left) - 30 ))  # Leaves time to pack what came of it.
echo "== dagger seeds ${list[*]} side by side (limit $limit s): ${files[*]} ${bindings[*]}" >>"$log"
for s in "${list[@]}"; do
  # Up to 200 rounds; the limit ends them sooner (the cut round is lost).
  ( t0=$(date +%s)
    timeout "$limit" $py benchmarks/train_dagger.py --base_dir="$runs/seed_$s" \
      --seed="$s" --rounds=200 "${files[@]}" "${bindings[@]}" >"$out/seed_$s.log" 2>&1
    echo "-- dagger seed $s: rc $? in $(( $(date +%s) - t0 )) s" >>"$log" ) &
done
wait
for s in "${list[@]}"; do
  echo "== seed $s" >>"$log"; grep -E '^round|validation TW50|Error|error' "$out/seed_$s.log" >>"$log"
  mkdir -p "$runs/pack/seed_$s"
  cp "$runs/seed_$s"/{run.json,summary.json,best_policy.msgpack} "$runs/pack/seed_$s/" 2>>"$log"
  tar cf "$out/seed_$s.tar" -C "$runs/pack" "seed_$s" 2>>"$log"
done
echo "== done in $(( $(date +%s) - start )) s" >>"$log"
