# ble_latex developer commands. Everything runs in a local virtualenv (.venv)
# that `make venv` creates or refreshes idempotently from constraints.txt.
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.ble_latex-installed
OUT ?= demo_output

.PHONY: venv demo test test-ci test-slow test-all docs docs-serve clean

venv: $(STAMP)

# Re-installs only when setup.py or constraints.txt change.
$(STAMP): setup.py constraints.txt
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[test,docs]'
	touch $(STAMP)

# The main job: a short demo run (see README "Quick start").
demo: venv
	$(PY) -m ble_latex.cli.demo --output_dir=$(OUT)

# Default test suite (slow tests excluded; see pytest.ini).
test: venv
	$(PY) -m pytest

# Slow tests CI runs after `test` (marked `ci`): the real RL clients (SB3 PPO,
# CleanRL-style SAC/PPO, purejaxrl PPO, RLlib PPO; each its examples/
# script's --short run), the Ray sweep killed and resumed, and the tests that
# start several processes (a trainer killed and resumed, a second trainer on
# one run directory, the eval command on Ray). XLA_FLAGS empty: compiled with
# XLA's defaults, as users compile (`make test` uses the loop emitters, see
# tests/conftest.py).
test-ci: venv
	XLA_FLAGS= $(PY) -m pytest -m ci

test-slow: venv
	$(PY) -m pytest -m slow

test-all: venv
	$(PY) -m pytest -m 'slow or not slow'

# The documentation site (mkdocs.yml, docs/) into site/; warnings are errors.
docs: venv
	$(VENV)/bin/mkdocs build --strict --site-dir site

docs-serve: venv
	$(VENV)/bin/mkdocs serve

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache site

# Issue 6 results: baselines and the shipped policy on the 100 held-out seeds
# of latex_small, then the table README shows (benchmarks/records/results_table.md).
RESULTS ?= benchmarks/results
EVAL := $(PY) -m ble_latex.cli.eval --suite=latex_small --output_dir=$(RESULTS)

.PHONY: baselines baselines-realistic realistic-task long-flights physics-results realistic-sensitivity planners planners-wide results env-speed batch-speed sac-step seed-parallel ray-eval train-sac select-sac ensemble learned-controller
baselines: venv
	$(EVAL) --agent=latex_random
	$(EVAL) --agent=latex_station_seeker
	$(EVAL) --agent=station_seeker --env_name=LatexBalloonDiscrete-v0 --name_override=ble_station_seeker_discrete
	$(EVAL) --agent=sac --name_override=sac_untrained

# Issue 28: the same evals under realistic latex physics, and 7-day flights
# (504 strides) in both modes; `physics-results` tabulates them side by side
# (benchmarks/records/physics_results.md). The realistic SAC seeds: benchmarks/sac_seeds.py
# with --gin_file=gin_configs/latex_realistic.gin (docs/physics.md).
REALISTIC_GIN := --gin_file=gin_configs/latex_realistic.gin
RESULTS_REALISTIC ?= benchmarks/results_realistic
RESULTS_STRESS ?= benchmarks/results_realistic_stress
# The paper-trained policy flown on realistic physics (sac_pretrained alone
# loads the policy trained on realistic physics before issue 44's calibration).
PAPER_POLICY := --gin_bindings='SACPretrainedAgent.policy_path="ble_latex/agents/policies/sac_latex.msgpack"' \
	--name_override=sac_pretrained_paper_policy
# Issue 44's stress setting of the lift disturbance (flight.params.LIFT_WALK_STRESS).
STRESS := --gin_bindings='latex_flight.lift_walk_kg_per_sqrt_s = 1.4e-3'
LONG := --max_episode_length=504 --gin_bindings=latex_episode.episode_steps=504
baselines-realistic: venv
	$(EVAL) --output_dir=$(RESULTS_REALISTIC) $(REALISTIC_GIN) --agent=latex_random
	$(EVAL) --output_dir=$(RESULTS_REALISTIC) $(REALISTIC_GIN) --agent=latex_station_seeker
	$(EVAL) --output_dir=$(RESULTS_REALISTIC) $(REALISTIC_GIN) --agent=station_seeker \
		--env_name=LatexBalloonDiscrete-v0 --name_override=ble_station_seeker_discrete
	$(EVAL) --output_dir=$(RESULTS_REALISTIC) $(REALISTIC_GIN) --agent=sac_pretrained
	$(EVAL) --output_dir=$(RESULTS_REALISTIC) $(REALISTIC_GIN) --agent=sac_pretrained $(PAPER_POLICY)
	$(EVAL) --output_dir=$(RESULTS_STRESS) $(REALISTIC_GIN) $(STRESS) --agent=latex_station_seeker
	$(EVAL) --output_dir=$(RESULTS_STRESS) $(REALISTIC_GIN) $(STRESS) --agent=sac_pretrained $(PAPER_POLICY)

# Issue 63: the realistic task (3.14 kg of sand, gin_configs/latex_realistic_task.gin)
# on the held-out seeds: the baselines in 3-day and 7-day flights. The SAC seeds
# trained on it: benchmarks/sac_seeds.py with $(TASK_GIN) and
# gin_configs/latex_sun_observation.gin (docs/physics.md, "The realistic task").
TASK_GIN := $(REALISTIC_GIN) --gin_file=gin_configs/latex_realistic_task.gin
RESULTS_TASK ?= benchmarks/results_realistic_task
RESULTS_TASK_LONG ?= benchmarks/results_7day_realistic_task
realistic-task: venv
	$(EVAL) --output_dir=$(RESULTS_TASK) $(TASK_GIN) --agent=latex_station_seeker
	$(EVAL) --output_dir=$(RESULTS_TASK) $(TASK_GIN) --agent=station_seeker \
		--env_name=LatexBalloonDiscrete-v0 --name_override=ble_station_seeker_discrete
	$(EVAL) --output_dir=$(RESULTS_TASK) $(TASK_GIN) --agent=sac_pretrained $(PAPER_POLICY)
	$(EVAL) --output_dir=$(RESULTS_TASK) $(TASK_GIN) --agent=sac_pretrained \
		--name_override=sac_pretrained_realistic_before_68
	$(EVAL) --output_dir=$(RESULTS_TASK_LONG) $(LONG) $(TASK_GIN) --agent=latex_station_seeker
	$(EVAL) --output_dir=$(RESULTS_TASK_LONG) $(LONG) $(TASK_GIN) --agent=sac_pretrained $(PAPER_POLICY)

long-flights: venv
	$(EVAL) --output_dir=benchmarks/results_7day $(LONG) --agent=latex_station_seeker
	$(EVAL) --output_dir=benchmarks/results_7day $(LONG) --agent=sac_pretrained
	$(EVAL) --output_dir=benchmarks/results_7day_realistic $(LONG) $(REALISTIC_GIN) --agent=latex_station_seeker
	$(EVAL) --output_dir=benchmarks/results_7day_realistic $(LONG) $(REALISTIC_GIN) --agent=sac_pretrained
	$(EVAL) --output_dir=benchmarks/results_7day_realistic $(LONG) $(REALISTIC_GIN) --agent=sac_pretrained $(PAPER_POLICY)

physics-results: venv
	$(PY) benchmarks/physics_results.py --json=benchmarks/records/physics_results.json \
		--paper=$(RESULTS)/latex_small --realistic=$(RESULTS_REALISTIC)/latex_small \
		--realistic_stress=$(RESULTS_STRESS)/latex_small \
		--paper_long=benchmarks/results_7day/latex_small \
		--realistic_long=benchmarks/results_7day_realistic/latex_small | tee benchmarks/records/physics_results.md

# Issue 44: days aloft and TW50 against the lift disturbance and the diurnal
# swing (docs/physics.md), 7-day flights of 64 latex_small seeds per cell.
realistic-sensitivity: venv
	$(PY) benchmarks/realistic_sensitivity.py \
		--agents=latex_station_seeker,sac_pretrained \
		--json=benchmarks/records/realistic_sensitivity.json \
		--png=docs/assets/realistic_sensitivity.png

# Issue 29: the planners on the same 100 seeds, balloons batched (resumable;
# docs/planners.md). Their records join the table.
PLANNERS ?= benchmarks/records/planners/results
planners: venv
	$(PY) benchmarks/planners.py --agent=latex_mpc --suite=latex_small --output_dir=$(PLANNERS)
	$(PY) benchmarks/planners.py --agent=latex_mpc_oracle --suite=latex_small --output_dir=$(PLANNERS)
	$(PY) benchmarks/planners.py --agent=latex_mpc_grad --suite=latex_small --output_dir=$(PLANNERS)

# The receding-horizon oracle with the wide search chosen on latex_validation
# (docs/planners.md, "On a GPU"; the oracle's default now plans the whole
# episode): 80 s on an H100, not timed on the CPU. Not part of `make results`.
WIDE_ORACLE := $(foreach b,beam_width=128 horizon=72 num_segments=12 replan_every=2 beam_cell_km=0 discount=1.0,--gin_bindings=LatexMpcOracleAgent.$(b))
planners-wide: venv
	$(PY) benchmarks/planners.py --agent=latex_mpc_oracle --suite=latex_small --batch=100 \
		--name_override=latex_mpc_oracle_wide --output_dir=$(PLANNERS) $(WIDE_ORACLE)

results: baselines planners
	$(EVAL) --agent=sac_pretrained
	$(EVAL) --agent=sac_ensemble --gin_file=gin_configs/latex_wind_memory.gin
	$(PY) benchmarks/results_table.py --json=benchmarks/records/results_table.json $(RESULTS)/latex_small/*.json \
		$(PLANNERS)/latex_small/*.json | tee benchmarks/records/results_table.md

env-speed: venv
	$(PY) benchmarks/env_speed.py --episodes 3 --repeats 3 --profile --json benchmarks/records/env_speed.json

batch-speed: venv
	$(PY) benchmarks/batch_speed.py --json benchmarks/records/batch_speed.json

sac-step: venv
	$(PY) benchmarks/sac_step.py --steps 200 --rounds 3 --json benchmarks/records/sac_step.json

seed-parallel: venv
	$(PY) benchmarks/seed_parallel.py --num_seeds 2 --rounds 5 --json benchmarks/records/seed_parallel.json

ray-eval: venv
	$(PY) benchmarks/ray_eval.py --json benchmarks/records/ray_eval.json

# Issue 6 training: the paper's SAC run (resumable), then the policy chosen on
# latex_validation is written into the package (see README "Results").
RUN ?= runs/sac_paper
train-sac: venv
	$(PY) benchmarks/train_sac.py train --base_dir=$(RUN) --episodes=2500

# Issue 47: SAC policies alone and as critic-chosen ensembles (benchmarks/records/ensemble/, docs/ensemble.md); the
# seeds' chosen policies come from `benchmarks/sac_seeds.py report` (git-ignored).
ENSEMBLE ?= benchmarks/records/ensemble
# The whole recipe in one command, resumable (each step resumes or skips what is done), seeded: the members'
# SAC seeds on each wind column, each seed's snapshot chosen on validation, then `ensemble` (about 7 hours of
# the 2-core machine, docs/ensemble.md). Copy the chosen members into ble_latex/agents/policies/ to ship them.
LEARNED_ROUNDS ?= 230
learned-controller: venv
	$(PY) benchmarks/sac_seeds.py train --base_dir=benchmarks/records/sac_jax/wind_lookahead12 --seeds=0,1,2,3,4,5 \
		--num_iterations=$(LEARNED_ROUNDS) --parallel=3 --gin_file=gin_configs/latex_wind_lookahead.gin
	$(PY) benchmarks/sac_seeds.py train --base_dir=benchmarks/records/sac_jax/wind_memory16 --seeds=0,1,2,3,4 \
		--num_iterations=$(LEARNED_ROUNDS) --parallel=3 --gin_file=gin_configs/latex_wind_memory.gin
	$(PY) benchmarks/sac_seeds.py train --base_dir=benchmarks/records/sac_jax/memory_lookahead --seeds=0 \
		--num_iterations=$(LEARNED_ROUNDS) --parallel=1 --gin_file=gin_configs/latex_wind_memory_lookahead.gin
	$(PY) benchmarks/sac_seeds.py report --base_dir=benchmarks/records/sac_jax/wind_lookahead12 --seeds=0,1,2,3,4,5 \
		--max_iteration=$$(($(LEARNED_ROUNDS) - 1)) --parallel=2 --gin_file=gin_configs/latex_wind_lookahead.gin
	$(PY) benchmarks/sac_seeds.py report --base_dir=benchmarks/records/sac_jax/wind_memory16 --seeds=0,1,2,3,4 \
		--max_iteration=$$(($(LEARNED_ROUNDS) - 1)) --parallel=2 --gin_file=gin_configs/latex_wind_memory.gin
	$(PY) benchmarks/sac_seeds.py report --base_dir=benchmarks/records/sac_jax/memory_lookahead --seeds=0 \
		--max_iteration=$$(($(LEARNED_ROUNDS) - 1)) --parallel=1 --gin_file=gin_configs/latex_wind_memory_lookahead.gin
	$(MAKE) ensemble

ensemble: venv
	$(PY) benchmarks/policy_select.py --sweep=$(ENSEMBLE)/results.json --drift_seeds=0,1,2,3,4,5 \
		--memory_seeds=0,1,2,3,4 --both_seeds=0
	$(PY) -m ble_latex.cli.eval --agent=sac_ensemble --suite=latex_small --output_dir=$(ENSEMBLE) \
		--gin_file=gin_configs/latex_wind_memory.gin
	$(PY) -c "import json, sys; p = sys.argv[1]; r = json.load(open(p)); [f.pop('flight_path') for f in r]; \
		json.dump(r, open(p, 'w'), indent=0)" $(ENSEMBLE)/latex_small/sac_ensemble.json

select-sac: venv
	$(PY) benchmarks/train_sac.py select --base_dir=$(RUN) --every=10 --include_newest --validation_episodes=30 \
		--output=ble_latex/agents/policies/sac_latex.msgpack
