#!/bin/bash
# DAgger at a GPU's scale (issue 47): the forecast planner `latex_mpc` labels
# every stride of NUM_BALLOONS flights per round (`ble_latex.run.dagger`,
# benchmarks/train_dagger.py), where a 2-core CPU labels 4 flights in ~8 min.
# Seeds train one after another, each with an equal share of BUDGET_S; a
# seed's rounds run until its share is spent (the cut round is lost, the
# finished ones kept: a run resumes from its newest round, and the same
# command with a run directory carried back continues it).
# The run directories sit in $RUNS (default /tmp/dagger_runs): the aggregate in
# a checkpoint is too big to come back. Into OUT/seed_S go run.json,
# summary.json (per-round validation on latex_validation, wall times) and
# best_policy.msgpack; fly the students on this machine's CPU afterwards:
#   ble-latex-eval --agent=sac_pretrained --suite=latex_small \
#     --gin_bindings="SACPretrainedAgent.policy_path='OUT/seed_S/best_policy.msgpack'"
# Needs what benchmarks/gpu/prepare_site.sh builds (gpu_site/). Usage, in the
# checkout: bash benchmarks/gpu/dagger.sh OUT BUDGET_S [SEEDS] [NUM_BALLOONS]
set -u
out=${1:?usage: dagger.sh OUT BUDGET_S [SEEDS] [NUM_BALLOONS]}
budget=${2:-540}
seeds=${3:-0,1,2}
balloons=${4:-256}
start=$(date +%s)
export PYTHONPATH=$PWD:$PWD/gpu_site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
py=${PYTHON:-python3}
runs=${RUNS:-/tmp/dagger_runs}
log=$out/log.txt
mkdir -p "$out" "$runs"
. "$(dirname "$0")/budget.sh"
{ date -u; nvidia-smi -L; $py -c 'import jax; print("jax", jax.__version__, jax.devices())'; uptime; } >>"$log" 2>&1
IFS=, read -ra list <<<"$seeds"
share=$(( ($(left) - 20) / ${#list[@]} ))
for s in "${list[@]}"; do
  budget_end=$(( $(date +%s) + share ))
  # Up to 60 rounds; the share's timeout ends it sooner (the cut round is lost).
  step "dagger seed $s" timeout $(( budget_end - $(date +%s) )) \
    $py benchmarks/train_dagger.py --base_dir="$runs/seed_$s" --seed="$s" --rounds=60 \
    --gin_bindings="dagger_config.num_balloons = $balloons" \
    --gin_bindings='dagger_config.validation_seeds = 100' \
    --gin_bindings='dagger_config.fit_steps = 2000'
  mkdir -p "$out/seed_$s"
  cp "$runs/seed_$s"/{run.json,summary.json,best_policy.msgpack} "$out/seed_$s/" 2>>"$log"
done
echo "== done in $(( $(date +%s) - start )) s" >>"$log"
