#!/bin/bash
# The planners where a CPU is too slow for them (issues 44 and 45), on a lent
# GPU inside a time budget; prepared by benchmarks/gpu/prepare_site.sh:
#   1. latex_mpc and the oracle on latex_small's 100 seeds under the
#      calibrated gin_configs/latex_realistic.gin (benchmarks/planners.py;
#      records OUT/p/latex_small/*_realistic.json);
#   2. both on the two GFS analyses (per-seed stations) and the two
#      soundings (at their sites), 100 seeds each (benchmarks/real_winds.py,
#      merged into a copy of the committed record: OUT/real_winds.json;
#      --overwrite re-flies the cells flown at BLE's noise scale 1 before
#      issue 64's default, and resumes those flown at it).
# Steps run in order while BUDGET_S lasts (each one's limit is what is left);
# a cut step keeps what it finished (planners.py's partial file, real_winds'
# finished cells). Timing files end up in OUT/timing.tar; the log in
# OUT/log.txt. Usage, in the checkout:
#   bash benchmarks/gpu/real_and_realistic.sh OUT BUDGET_S [PARTS]
# PARTS: `realistic`, `real` or `realistic,real` (the default): which of
# steps 1 and 2 run (step 1's records are committed since 2026-11-28).
set -u
out=${1:?usage: real_and_realistic.sh OUT BUDGET_S [PARTS]}
budget=${2:-540}
parts=,${3:-realistic,real},
start=$(date +%s)
export PYTHONPATH=$PWD:$PWD/gpu_site${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
py=${PYTHON:-python3}
log=$out/log.txt
mkdir -p "$out"
. "$(dirname "$0")/budget.sh"
{ date -u; nvidia-smi -L; $py -c 'import jax; print("jax", jax.__version__, jax.devices())'; uptime; } >>"$log" 2>&1
cp benchmarks/records/real_winds.json "$out/real_winds.json"
for agent in latex_mpc latex_mpc_oracle; do
  [[ $parts == *,realistic,* ]] || continue
  step "$agent realistic" $py benchmarks/planners.py --agent=$agent --suite=latex_small \
    --gin_file=gin_configs/latex_realistic.gin --output_dir="$out/p" \
    --name_override=${agent}_realistic
done
sha=$(cat gpu_data/gfs_global.sha256)
[[ $parts == *,real,* ]] && step "real winds, GFS" $py benchmarks/real_winds.py --agents=latex_mpc,latex_mpc_oracle \
  --sources=gfs_namerica,gfs_global --station_mode=per_seed --seeds=100 --overwrite \
  --realdata_dir=gpu_data/realdata --json="$out/real_winds.json" \
  --source_copy="gfs_global=gpu_data/gfs_global.nc@$sha"
[[ $parts == *,real,* ]] && step "real winds, soundings" $py benchmarks/real_winds.py --agents=latex_mpc,latex_mpc_oracle \
  --sources=hilo,boise --station_mode=center --seeds=100 --overwrite \
  --realdata_dir=gpu_data/realdata --json="$out/real_winds.json"
(cd "$out/p/latex_small" 2>/dev/null && tar cf "$out/timing.tar" timing *.partial.json 2>/dev/null)
echo "== done in $(( $(date +%s) - start )) s" >>"$log"
