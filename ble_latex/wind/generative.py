# coding=utf-8
"""BLE's generative (VAE) wind forecast, decoded and interpolated in JAX.

Reproduces BLE 1.0.1's `generative_wind_field.GenerativeWindField` as pure,
jittable and vmappable JAX functions:

- `reset_forecast(key, params)`: BLE's `GenerativeWindField.reset_forecast`:
  64 standard-normal latents drawn from the key, decoded by BLE's own
  `vae.Decoder` into a (21, 21, 10, 9, 2) grid of (u, v) winds [m/s] over
  x, y in [-500, 500] km, pressure in [5000, 14000] Pa and time in [0, 48] h.
  `jax.vmap(reset_forecast, in_axes=(0, None))` (or `reset_forecasts`)
  decodes a batch of keys in one call.
- `forecast(field, x_m, y_m, pressure_pa, t_s)`: BLE's `get_forecast`:
  x, y and pressure clipped to the grid, time beyond the 48-h horizon folded
  back by BLE's `_boomerang`, the query point rounded to float32 (BLE builds
  it in a float32 array), then `scipy.interpolate.interpn`'s multilinear
  interpolation (scipy's interval search and normalised distances).
- `forecast_column(field, x_m, y_m, pressures, t_s)`: BLE's
  `get_forecast_column` (the same at several pressures).
- `split_wind_key(key)`: BLE's `WindField.reset` key split (noise key,
  forecast key); the noise is `ble_latex.wind.simplex`.
- `decoder_params()`: BLE's offline decoder weights (offlineskies22), read
  and restored once per process.

Precision of queries. They compute in the floating dtype of their inputs.
- float64 (float64 inputs inside a local `with jax.enable_x64(True):`
  scope): the point is still rounded to float32 as BLE's, and the 16 corner
  terms are weighted and summed as scipy's `_evaluate_linear` does, in its
  order: BLE's value within 1e-14 m/s (XLA may contract a multiply-add).
- float32 (JAX's default): the same point, interpolated one dimension at a
  time on the corners' differences (see `_nested_linear`): within 2e-6 m/s
  of BLE's value for the same float32 point (scipy's 16-term sum in float32
  would be ~7e-6 m/s off). Divisions by constants are kept true divisions
  (`divide`): XLA's reciprocal multiplication would move the float32 point.
  Inputs held in float32 are themselves rounded: a time of 10 days in
  float32 seconds is only known to 1/16 s (~1e-5 m/s of wind change).
The decoded grid is float32 as BLE's: decoding one key under `jax.jit` gives
BLE's eager decode bit for bit (on CPU); a vmapped batch uses matrix-matrix
kernels with another float32 summation order (<= ~2e-4 m/s apart), and
`reset_forecasts(..., exact=True)` decodes one key at a time (bit-identical,
~3x slower).

Deviations from BLE, where BLE raises: a time before the field's start is
clamped to 0 h (BLE: scipy's out-of-bounds ValueError); a NaN coordinate
gives NaN winds (BLE: ValueError).
"""

import concurrent.futures
import functools
import importlib
import importlib.resources
import itertools
import sys
from typing import Any, Optional, Sequence, Tuple

from balloon_learning_environment.generative import vae
import flax
import jax
import jax.numpy as jnp
import numpy as np

from ble_latex import dtypes

NUM_LATENTS = 64  # BLE's latent dimension (GenerativeWindField.reset_forecast).
SECONDS_PER_HOUR = 3600.0  # [s/h]


def _axis(values: Any) -> Tuple[float, ...]:
  """A grid axis as Python floats (exact values of BLE's float32/int32 axis)."""
  return tuple(float(v) for v in np.asarray(values, dtype=np.float64))


def _compute_ble_grid_axes() -> Tuple[Tuple[float, ...], ...]:
  """BLE's `_grid` from `vae.FieldShape`, eagerly, without x64."""
  shape = vae.FieldShape()
  with jax.enable_x64(False):
    axes = (shape.latlng_grid_points(), shape.latlng_grid_points(),
            shape.pressure_grid_points(), shape.time_grid_points())
    return tuple(_axis(np.asarray(axis)) for axis in axes)


@functools.lru_cache(maxsize=None)
def ble_grid_axes() -> Tuple[Tuple[float, ...], ...]:
  """BLE's grid axes (`GenerativeWindField._grid`), exactly as BLE has them.

  Computed once with BLE's own `vae.FieldShape` methods, eagerly and without
  x64 as in BLE: the latitude/longitude points carry the float32 rounding of
  an eager `jnp.linspace` (e.g. -49.99997 km, 100.000015 km), which neither
  numpy nor a traced or constant-folded linspace reproduces. The computation
  runs in a helper thread (JAX's trace and x64 contexts are thread-local), so
  that a first call from inside `jax.jit` or an x64 scope is still eager.

  Returns:
    (x [km], y [km], pressure [Pa], time [h]) grid points as float tuples.
  """
  with concurrent.futures.ThreadPoolExecutor(max_workers=1) as executor:
    return executor.submit(_compute_ble_grid_axes).result()


@flax.struct.dataclass
class ForecastField:
  """A decoded generative forecast: BLE's `GenerativeWindField.field` + grid.

  A pytree: `grid` is its only array leaf, the axes are static. A batch of
  fields (e.g. from `reset_forecasts`) has a leading axis on `grid`; query it
  with `jax.vmap(forecast, in_axes=(0, ...))`.

  Attributes:
    grid: float32 [..., 21, 21, 10, 9, 2]: (u, v) winds [m/s] at
      (x, y, pressure, time) grid points, BLE's decoder output layout.
    axes: Static: (x [km], y [km], pressure [Pa], time [h]) grid points as
      float tuples; the last time point is the boomerang horizon. None
      (default): BLE's grid, `ble_grid_axes()`.
  """
  grid: jnp.ndarray
  axes: Optional[Tuple[Tuple[float, ...], ...]] = flax.struct.field(
      pytree_node=False, default=None)

  def grid_axes(self) -> Tuple[Tuple[float, ...], ...]:
    """(x [km], y [km], pressure [Pa], time [h]) grid points."""
    return ble_grid_axes() if self.axes is None else self.axes

  @classmethod
  def from_array(cls, field: Any) -> 'ForecastField':
    """Wraps a BLE field array, e.g. a reset `GenerativeWindField.field`.

    Args:
      field: [21, 21, 10, 9, 2] (u, v) winds on BLE's grid. # [m/s]

    Returns:
      The ForecastField on BLE's grid (the array as float32).
    """
    return cls(grid=jnp.asarray(field, dtype=jnp.float32))


@functools.lru_cache(maxsize=None)
def decoder_params(path: Optional[str] = None) -> Any:
  """BLE's offline VAE decoder weights (offlineskies22), loaded once.

  As `GenerativeWindField.__init__`: the msgpack bytes of
  `models.load_offlineskies22` restored with `flax.serialization.
  msgpack_restore`. Without a path, if BLE's `models` module is already
  imported (a BLE env exists) its loader is called, so a gin binding of
  `load_offlineskies22.path` is honoured as in BLE; otherwise the weights
  packaged with BLE are read directly (BLE's loader's own second attempt),
  which avoids importing TensorFlow. The result is cached per path: do not
  modify it.

  Args:
    path: Optional file of serialized decoder weights (BLE's `path`).

  Returns:
    The decoder variables {'params': {'Dense_0': ..., ..., 'Dense_3': ...}}
    as JAX arrays, for `vae.Decoder().apply`.
  """
  if path is not None:
    with open(path, 'rb') as f:
      serialized = f.read()
  else:
    models = sys.modules.get('balloon_learning_environment.models.models')
    if models is not None:
      serialized = models.load_offlineskies22()
    else:
      resource = importlib.resources.files(
          'balloon_learning_environment.models').joinpath(
              'offlineskies22_decoder.msgpack')
      try:
        serialized = resource.read_bytes()
      except FileNotFoundError:  # Not a packaged install: BLE's loader.
        serialized = importlib.import_module(
            'balloon_learning_environment.models.models').load_offlineskies22()
  params = flax.serialization.msgpack_restore(serialized)
  return jax.tree_util.tree_map(jnp.asarray, params)


def split_wind_key(key: jnp.ndarray) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """BLE's `WindField.reset` key split: (noise_key, forecast_key).

  BLE's wind field `reset(key, date_time)` resets its simplex noise with the
  first half of `jax.random.split(key, 2)` and its forecast
  (`reset_forecast`) with the second.

  Args:
    key: The key given to BLE's `WindField.reset`.

  Returns:
    (noise_key, forecast_key).
  """
  noise_key, forecast_key = jax.random.split(key, num=2)
  return noise_key, forecast_key


@jax.jit
def reset_forecast(key: jnp.ndarray, params: Any) -> ForecastField:
  """BLE's `GenerativeWindField.reset_forecast(key, ...)`: the decoded field.

  latents = `jax.random.normal(key, (64,))`, field = `vae.Decoder().apply(
  params, latents)`, traced without x64 as BLE runs it (also when called
  inside an x64 scope, where float64 intermediates would shift the field by
  ~3e-5 m/s). Jitted; vmap over keys for a batch (`reset_forecasts`).

  Args:
    key: The forecast key (the second of `split_wind_key(key)` for the key
      of BLE's `WindField.reset`).
    params: Decoder variables, `decoder_params()`.

  Returns:
    The ForecastField (grid float32 [21, 21, 10, 9, 2], [m/s]).
  """
  with jax.enable_x64(False):  # BLE decodes without x64.
    latents = jax.random.normal(key, shape=(NUM_LATENTS,), dtype=jnp.float32)
    return ForecastField(grid=vae.Decoder().apply(params, latents))


@functools.partial(jax.jit, static_argnames=('exact',))
def reset_forecasts(keys: jnp.ndarray, params: Any,
                    exact: bool = False) -> ForecastField:
  """`reset_forecast` for a batch of keys [N, ...], decoded in one call.

  Args:
    keys: N forecast keys (stacked along axis 0).
    params: Decoder variables, `decoder_params()`.
    exact: False: `jax.vmap` (batched matrix-matrix products: fastest, but
      another float32 summation order than BLE's one-field decode, ~1e-4 m/s
      apart). True: `jax.lax.map`, one field at a time with BLE's shapes:
      the fields of BLE's single decodes (bit-identical on CPU), ~3x slower.

  Returns:
    A batched ForecastField (grid float32 [N, 21, 21, 10, 9, 2], [m/s]).
  """
  if exact:
    return jax.lax.map(lambda key: reset_forecast(key, params), keys)
  return jax.vmap(reset_forecast, in_axes=(0, None))(keys, params)


def divide(numerator: jnp.ndarray, denominator: float) -> jnp.ndarray:
  """numerator / denominator, correctly rounded also under `jax.jit`.

  XLA rewrites a division by a constant (or by a broadcast scalar) into a
  multiplication by its rounded reciprocal, which is off by one ulp for
  about half of the float32 inputs (e.g. x_m / 1000): enough to move BLE's
  float32 query point. A divisor that XLA cannot prove constant (NaN where
  the numerator is NaN, which gives NaN either way) keeps a true division.
  """
  return numerator / jnp.where(jnp.isnan(numerator), numerator, denominator)


def _to_float32_point(value: jnp.ndarray) -> jnp.ndarray:
  """Rounds to float32 as BLE's float32 point array, kept in value's dtype."""
  return value.astype(jnp.float32).astype(value.dtype)


def _locate(axis: Tuple[float, ...],
            value: jnp.ndarray) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """scipy's interval search: (i, (v - g[i]) / (g[i + 1] - g[i])).

  i is such that g[i] <= v < g[i + 1], or n - 2 for v = g[-1] (scipy's
  `find_indices` for points inside the grid).
  """
  grid = jnp.asarray(axis, dtype=value.dtype)
  i = jnp.searchsorted(grid, value, side='right', method='compare_all') - 1
  i = jnp.clip(i, 0, len(axis) - 2)
  lower = grid[i]
  return i, (value - lower) / (grid[i + 1] - lower)


def field_time_hours(t_s: Any, horizon_h: float) -> jnp.ndarray:
  """BLE's time position in the field, with `_boomerang` beyond the horizon.

  BLE's `_prepare_get_forecast_inputs`: before the horizon the time is used
  as is; from the horizon on, `GenerativeWindField._boomerang` runs it
  backwards to 0 over the next horizon, then forwards again (forward when
  int(t / T) is even, t % T forward, T - t % T backward). In float64 this is
  BLE's arithmetic in BLE's order (hours first, folded in hours). In float32
  the time is folded in seconds, exactly, then converted to hours: folding
  float32 hours would lose ~1e-5 h beyond the horizon. A negative time is
  clamped to 0 (BLE raises).

  Args:
    t_s: Time since the start of the field. # [s]
    horizon_h: The field's time horizon (48 h in BLE). # [h]

  Returns:
    The time position in [0, horizon_h], in the dtype of t_s. # [h]
  """
  t_s = jnp.asarray(t_s)
  t_s = t_s.astype(dtypes.float_dtype(t_s))
  if t_s.dtype == jnp.float64:  # BLE's: int(t / T) % 2, t % T in hours.
    t, horizon = divide(t_s, SECONDS_PER_HOUR), horizon_h
    remainder = jnp.mod(t, horizon)
    cycles = jnp.trunc(divide(t, horizon))
  else:  # The cycle count consistent with the (exact) remainder.
    t, horizon = t_s, horizon_h * SECONDS_PER_HOUR
    remainder = jnp.mod(t, horizon)
    cycles = jnp.round(divide(t - remainder, horizon))
  backward = jnp.mod(cycles, 2) == 1
  folded = jnp.where(backward, horizon - remainder, remainder)
  position = jnp.where(t < horizon, t, folded)
  if t_s.dtype != jnp.float64:
    position = divide(position, SECONDS_PER_HOUR)
  return jnp.maximum(position, 0.0)


def forecast(field: ForecastField, x_m: Any, y_m: Any, pressure_pa: Any,
             t_s: Any) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """BLE's `GenerativeWindField.get_forecast`: the forecast wind (u, v).

  BLE's `_prepare_get_forecast_inputs` (x, y [km] clipped to +-500 km,
  pressure clipped to [5000, 14000] Pa, time boomeranged beyond 48 h, the
  point rounded to float32) followed by `scipy.interpolate.interpn`'s
  multilinear interpolation, in scipy's order of operations. Inputs
  broadcast against each other; computed in their floating dtype (see the
  module docstring for precision). Jittable; vmap over a batch of fields.

  Args:
    field: One ForecastField (grid [21, 21, 10, 9, 2]).
    x_m: Distance east of the station. # [m]
    y_m: Distance north of the station. # [m]
    pressure_pa: Pressure. # [Pa]
    t_s: Time since the start of the field. # [s]

  Returns:
    (u, v) of the broadcast input shape, eastward and northward. # [m/s]
  """
  dtype = dtypes.float_dtype(x_m, y_m, pressure_pa, t_s)
  x_m, y_m, pressure_pa, t_s = jnp.broadcast_arrays(
      *(jnp.asarray(v, dtype) for v in (x_m, y_m, pressure_pa, t_s)))
  located = _locate_point(field, x_m, y_m, pressure_pa, t_s)
  # The 16 corners' (u, v): [..., 2, 2, 2, 2, 2] (lower / upper corner in x,
  # y, pressure, time; then u, v): one 2 x 2 x 2 x 2 x 2 slice per point.
  indices = jnp.stack([i for i, _ in located], axis=-1)
  flat = indices.reshape(-1, 4)
  block = jax.vmap(lambda i: jax.lax.dynamic_slice(
      field.grid, (*i, jnp.zeros_like(i[0])), (2, 2, 2, 2, 2)))(flat)
  block = block.reshape(indices.shape[:-1] + block.shape[1:])
  return _interpolate(block, [y for _, y in located])


def _locate_point(field: ForecastField, x_m: jnp.ndarray, y_m: jnp.ndarray,
                  pressure_pa: jnp.ndarray, t_s: jnp.ndarray
                  ) -> Sequence[Tuple[jnp.ndarray, jnp.ndarray]]:
  """BLE's query point on the grid: (index, fraction) per axis (x, y, P, t).

  BLE's point: units.Distance.kilometers, np.clip, the time boomeranged,
  then a float32 array; then scipy's interval search (`_locate`).
  """
  axes = field.grid_axes()
  x_km, y_km, pressure_axis, time_h = axes
  point = (
      jnp.clip(divide(x_m, 1000.0), x_km[0], x_km[-1]),
      jnp.clip(divide(y_m, 1000.0), y_km[0], y_km[-1]),
      jnp.clip(pressure_pa, pressure_axis[0], pressure_axis[-1]),
      field_time_hours(t_s, time_h[-1]),
  )
  point = [_to_float32_point(p) for p in point]
  return [_locate(axis, p) for axis, p in zip(axes, point)]


def _interpolate(block: jnp.ndarray, fractions: Sequence[jnp.ndarray]
                 ) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """(u, v) of the corner block [..., 2, 2, 2, 2, 2] at the fractions."""
  block = block.astype(fractions[0].dtype)
  if block.dtype == jnp.float64:
    uv = _scipy_linear(block, fractions)
  else:
    uv = _nested_linear(block, fractions)
  return uv[..., 0], uv[..., 1]


def _scipy_linear(block: jnp.ndarray, fractions: Sequence[jnp.ndarray]
                  ) -> jnp.ndarray:
  """scipy's `RegularGridInterpolator._evaluate_linear`, in scipy's order.

  Per corner weight = ((1 * w0) * w1) * w2 * w3 with w = 1 - y (lower) or y
  (upper), value = 0 + term_0 + term_1 + ..., corners in `itertools.product`
  order. Used in float64, where it reproduces BLE's value (XLA may still
  contract a multiply-add: <= 1e-14 m/s).
  """
  value = None
  for corner in itertools.product((0, 1), repeat=4):
    weight = None
    for y, c in zip(fractions, corner):
      w = y if c else 1.0 - y
      weight = w if weight is None else weight * w
    term = block[(Ellipsis,) + corner + (slice(None),)] * weight[..., None]
    value = term if value is None else value + term
  return value


def _nested_linear(block: jnp.ndarray, fractions: Sequence[jnp.ndarray]
                   ) -> jnp.ndarray:
  """The same multilinear interpolation, accurate in float32.

  Interpolates the corners' differences from the first corner, one
  dimension at a time (a + y (b - a), time first), then adds that corner
  back. Unlike scipy's sum of 16 weighted terms (whose float32 weights do not
  sum exactly to 1), this is exact for a constant field and keeps the
  float32 error within ~2e-6 m/s of BLE's float64 value instead of ~7e-6.
  """
  base = block[..., 0, 0, 0, 0, :]
  value = block - base[..., None, None, None, None, :]
  for y in reversed(fractions):  # Time, pressure, y, x: always axis -2.
    lower, upper = value[..., 0, :], value[..., 1, :]
    y = y.reshape(y.shape + (1,) * (lower.ndim - y.ndim))
    value = lower + y * (upper - lower)
  return base + value


def forecast_column(field: ForecastField, x_m: Any, y_m: Any, pressures: Any,
                    t_s: Any) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """BLE's `GenerativeWindField.get_forecast_column`: winds at many pressures.

  Args:
    field: One ForecastField.
    x_m: Distance east of the station (scalar). # [m]
    y_m: Distance north of the station (scalar). # [m]
    pressures: [L] pressure levels. # [Pa]
    t_s: Time since the start of the field (scalar). # [s]

  Returns:
    (u [L], v [L]) at the pressure levels. # [m/s]
  """
  dtype = dtypes.float_dtype(x_m, y_m, pressures, t_s)
  x_m, y_m, pressures, t_s = (jnp.asarray(v, dtype)
                              for v in (x_m, y_m, pressures, t_s))
  if x_m.ndim or y_m.ndim or t_s.ndim or pressures.ndim != 1:
    return forecast(field, x_m, y_m, pressures, t_s)
  # The column shares its x, y and time corners: one 2 x 2 x P x 2 x 2 slab,
  # then the two pressure planes of each level (the same corner values and
  # arithmetic as `forecast` at each level).
  (ix, fx), (iy, fy), (ip, fp), (it, ft) = _locate_point(
      field, x_m, y_m, pressures, t_s)
  num_pressures = field.grid.shape[-3]
  zero = jnp.zeros_like(ix)
  slab = jax.lax.dynamic_slice(field.grid, (ix, iy, zero, it, zero),
                               (2, 2, num_pressures, 2, 2))
  block = jax.vmap(lambda i: jax.lax.dynamic_slice_in_dim(slab, i, 2,
                                                          axis=2))(ip)
  return _interpolate(block, [jnp.broadcast_to(y, fp.shape)
                              for y in (fx, fy, fp, ft)])
