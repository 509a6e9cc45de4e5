"""The Gymnasium envs' compiled programs (`envs/gymnasium_compile.py`): fork
refusal, CPU options, compiling once ahead."""

import threading

import gymnasium
import jax
import numpy as np
import pytest

from ble_latex import jax_cache
from ble_latex.envs import gymnasium_compile
from ble_latex.envs import gymnasium_env
from ble_latex.envs import jax_env

from tests.envs import gymnasium_cases as cases


def test_forked_worker_fails_loudly_instead_of_hanging(monkeypatch):
  jax = pytest.importorskip('jax')
  jax.numpy.zeros(1).block_until_ready()  # JAX has started here.
  monkeypatch.setattr(gymnasium_compile, '_forked_after_jax', False)
  gymnasium_compile._note_fork_in_child()  # pylint: disable=protected-access
  assert gymnasium_compile._forked_after_jax  # pylint: disable=protected-access
  with pytest.raises(RuntimeError, match="spawn"):
    gymnasium.make(cases.ID, normalize_actions=False)


# -- Compilation (issue 26). --------------------------------------------------
def _fresh_env():
  """A single env whose programs are new to jit (compiled by this test)."""
  env = gymnasium_env.LatexBalloonGymnasiumEnv()
  env._fns = gymnasium_compile.Compiled(  # pylint: disable=protected-access
      jax_env.LatexBalloonJaxEnv(normalize_actions=False), batched=False)
  return env


@pytest.mark.skipif(jax.default_backend() != 'cpu', reason='CPU options')
def test_programs_compile_with_the_fast_cpu_options(monkeypatch):
  monkeypatch.setattr(jax_cache, 'CPU_FAST_COMPILE',
                      {'ble_latex_no_such_option': True})
  env = _fresh_env()
  key = jax_env.arena_key(jax.random.PRNGKey(0))
  with pytest.raises(Exception, match='ble_latex_no_such_option'):
    env._fns.draw.lower(key, env.params).compile()  # pylint: disable=protected-access


def test_first_reset_compiles_start_and_step_ahead_once():
  compiles = []

  def listen(event, seconds, **kwargs):
    del seconds
    if event == '/jax/core/compile/backend_compile_duration':
      compiles.append((str(kwargs.get('fun_name')),
                       threading.current_thread().name))

  env = _fresh_env()
  # Normalized actions (gymnasium.make's default) on the same programs.
  unit = gymnasium_env.LatexBalloonGymnasiumEnv(normalize_actions=True)
  unit._fns = env._fns  # pylint: disable=protected-access
  unit.compile_step_ahead = False
  jax.monitoring.register_event_duration_secs_listener(listen)
  try:
    env.reset(seed=0)
    env._fns.wait('step')  # pylint: disable=protected-access
    before_step = list(compiles)
    env.step(np.array([16_000.0, 1.0, 0.0], np.float32))
    after_step = list(compiles)
    unit.reset(seed=0)
    unit.step(np.array([0.5, 0.0, -1.0], np.float32))
  finally:
    jax.monitoring.unregister_event_duration_listener(listen)
  # `normalized` is an argument of the one step program, not a constant.
  assert compiles == after_step, 'normalized actions compiled another step'
  del compiles[len(after_step):]
  programs = {name: [t for f, t in compiles if f == f'jit({name})']
              for name in ('draw', 'start', 'step')}
  assert programs['draw'] == ['MainThread'], compiles
  assert len(programs['start']) == 1, compiles
  assert len(programs['step']) == 1, compiles
  assert programs['step'][0].startswith('ble_latex-compile'), compiles
  assert compiles == before_step, 'the first step compiled again'
