# coding=utf-8
"""The planners over the batched JAX flight core and their BLE agents.

- `config`: `PlannerConfig`, its checks and limits, the gin configurables
  `LatexMpcAgent`, `LatexMpcOracleAgent`, `LatexMpcGradAgent` (gin module
  string `ble_latex.agents.planners`, as before the package).
- `objective`: a plan's objective and the winds it is flown in.
- `beam`: beam search over a plan's segments.
- `value`: a learned value beyond the plan's horizon.
- `planner`: planning, one balloon or a batch (`plan`, `plan_batch`).
- `agents`: the planners as BLE agents (`AGENTS`).

Pure JAX except `agents` (BLE's agent base). Importing the package imports
none of them.
"""
