# coding=utf-8
"""OpenSimplex 0.3 4-D noise and BLE's simplex wind noise, in JAX.

Reproduces, as jittable and vmappable JAX functions:

- `permutation`: the permutation table that `opensimplex.OpenSimplex(seed)`
  (the `opensimplex` package, version 0.3, itself a port of Kurt Spencer's
  legacy OpenSimplex noise) builds from a 64-bit seed: a 64-bit LCG driving a
  Fisher-Yates shuffle. JAX without x64 has no 64-bit integers, so the LCG is
  computed exactly on (hi, lo) pairs of uint32 words.
- `noise4d`: `OpenSimplex.noise4d` of opensimplex 0.3, branch-free. The
  legacy 4-D algorithm does NOT sum every lattice vertex within the kernel
  radius: it picks 5 or 10 vertices of the stretched unit hypercube (by the
  region of the sum of the in-cell coordinates) plus 3 "extra" vertices
  chosen by a cascade of score comparisons, and it misses vertices whose
  attenuation is still positive for about 12 % of points (the legacy 4-D
  noise is slightly discontinuous). Summing a superset of vertices would thus
  differ from opensimplex by up to ~5e-6; instead the original's decisions
  are taken with `jnp.where` (the upper two regions as the mirror images of
  the lower two) and the same vertex set is read from a table of
  opensimplex's vertex rules: 13 vertex slots per point. The comparisons are
  made on the same float64 operations in the same order as the Python
  original, so ties are broken identically.
- `wind_noise`: BLE 1.0.1's `simplex_wind_noise.NoisyWindComponent.get_noise`
  (five harmonics of noise4d, weighted and variance-normalised), with its
  state in a pytree `NoiseParams` that `reset_noise_params` draws from a JAX
  key exactly as BLE's `reset` does, or `noise_params_from_ble` reads from a
  reset BLE component; `wind_noise_uv`: the u and v components at once (their
  10 harmonics in one vectorised noise4d).

Precision: every function computes in the floating dtype of its coordinate
inputs (float32 by default in JAX). In float64 `noise4d` agrees with
opensimplex to ~1e-15 (tests/wind/test_simplex.py checks 1e-9); run it in a
local x64 scope, without changing the process-wide setting:

  with jax.enable_x64(True):   # JAX 0.10: thread-local, restored on exit
    value = noise4d(perm, jnp.float64(x), ...)

(`jax.experimental.enable_x64` no longer exists in JAX 0.10.) In float32 the
error grows with the magnitude of the noise coordinates, about
1e-7 * (|x| + |y| + |z| + |w|): ~1e-6 for coordinates of order 1, ~3e-5 for
the coordinates of order 300 that BLE's pressure harmonics reach.

BLE itself computes its noise in float32: its harmonic offsets are numpy
float32 scalars, so under NumPy 2 (NEP 50) every `noise4d` argument and all
of opensimplex's arithmetic on them is float32. `wind_noise` in float64 is
the float64 value of BLE's formula with BLE's float32 offsets (to ~1e-13
m/s); BLE's own float32 values differ from it by up to ~2e-5 m/s, and
`wind_noise` in float32 from BLE's by up to ~5e-5 m/s (noise of a few m/s).
"""

import math
from typing import Any, Sequence, Tuple

from balloon_learning_environment.env import simplex_wind_noise
import flax
import jax
from jax import lax
import jax.numpy as jnp
import numpy as np

from ble_latex import dtypes

# opensimplex 0.3's 4-D constants.
STRETCH_CONSTANT_4D = -0.138196601125011  # (1 / sqrt(4 + 1) - 1) / 4
SQUISH_CONSTANT_4D = 0.309016994374947  # (sqrt(4 + 1) - 1) / 4
NORM_CONSTANT_4D = 30

# opensimplex 0.3's seed LCG (Knuth's MMIX constants), modulo 2**64.
_LCG_MULTIPLIER = 6364136223846793005
_LCG_INCREMENT = 1442695040888963407
_MASK32 = 0xFFFFFFFF


def _words(value: int) -> Tuple[np.uint32, np.uint32]:
  """(hi, lo) uint32 words of an integer modulo 2**64."""
  value %= 2**64
  return np.uint32(value >> 32), np.uint32(value & _MASK32)


_MUL_HI, _MUL_LO = _words(_LCG_MULTIPLIER)
_INC_HI, _INC_LO = _words(_LCG_INCREMENT)


def _gradients_4d() -> np.ndarray:
  """opensimplex's GRADIENTS_4D as a (64, 4) table.

  Row r is a permutation of (3, 1, 1, 1): the 3 is at axis r % 4, and axis k
  is negated when bit k of r // 4 is set.
  """
  rows = np.arange(64)[:, None]
  axes = np.arange(4)[None, :]
  magnitude = np.where(axes == rows % 4, 3, 1)
  sign = np.where((rows // 4 >> axes) & 1, -1, 1)
  return (magnitude * sign).astype(np.int32)


_GRADIENTS_4D = _gradients_4d()

# The 16 vertices of the stretched unit hypercube, (x, y, z, w) offsets from
# the cell origin, and how many of their coordinates are 1.
_CUBE = np.array([[(v >> k) & 1 for k in range(4)] for v in range(16)],
                 dtype=np.int32)
_CUBE_ONES = _CUBE.sum(axis=1, dtype=np.int32)


# ---------------------------------------------------------------------------
# Permutation table (OpenSimplex.__init__).


def _mul_wide(a: jnp.ndarray, b: jnp.ndarray) -> Tuple[jnp.ndarray,
                                                       jnp.ndarray]:
  """Full 64-bit product of two uint32 arrays, as (hi, lo) uint32 words."""
  a0, a1 = a & 0xFFFF, a >> 16
  b0, b1 = b & 0xFFFF, b >> 16
  p00, p01, p10, p11 = a0 * b0, a0 * b1, a1 * b0, a1 * b1  # each < 2**32
  middle = (p00 >> 16) + (p01 & 0xFFFF) + (p10 & 0xFFFF)  # < 3 * 2**16
  lo = (p00 & 0xFFFF) | (middle << 16)
  hi = p11 + (p01 >> 16) + (p10 >> 16) + (middle >> 16)
  return hi, lo


def _lcg(hi: jnp.ndarray, lo: jnp.ndarray) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """seed * 6364136223846793005 + 1442695040888963407 modulo 2**64."""
  hi_out, lo_out = _mul_wide(lo, _MUL_LO)
  hi_out = hi_out + lo * _MUL_HI + hi * _MUL_LO  # uint32 arithmetic wraps
  lo_sum = lo_out + _INC_LO
  carry = (lo_sum < lo_out).astype(jnp.uint32)
  return hi_out + _INC_HI + carry, lo_sum


def _shuffle_index(hi: jnp.ndarray, lo: jnp.ndarray,
                   modulus: jnp.ndarray) -> jnp.ndarray:
  """Python's `(seed + 31) % modulus` for the signed 64-bit seed (hi, lo).

  Args:
    hi: High word of the seed's two's complement (uint32).
    lo: Low word (uint32).
    modulus: 1 to 256 (int32).

  Returns:
    The non-negative remainder (int32), as Python's `%` gives it.
  """
  m = modulus.astype(jnp.uint32)
  two32 = (np.uint32(_MASK32) % m + 1) % m  # 2**32 mod m
  unsigned = ((hi % m) * two32 + lo % m) % m  # (hi 2**32 + lo) mod m
  two64 = (two32 * two32) % m  # 2**64 mod m
  negative = hi >= np.uint32(2**31)  # the seed is hi 2**32 + lo - 2**64
  remainder = (unsigned + 31 + m - jnp.where(negative, two64, 0)) % m
  return remainder.astype(jnp.int32)


@jax.jit
def _permutation_from_words(hi: jnp.ndarray, lo: jnp.ndarray) -> jnp.ndarray:
  """`permutation` of the 64-bit seed with two's complement words (hi, lo)."""
  for _ in range(3):
    hi, lo = _lcg(hi, lo)
  source = jnp.arange(256, dtype=jnp.int32)
  perm = jnp.zeros(256, dtype=jnp.int32)

  def draw(j, state):
    hi, lo, source, perm = state
    i = 255 - j
    hi, lo = _lcg(hi, lo)
    r = _shuffle_index(hi, lo, i + 1)
    perm = perm.at[i].set(source[r])
    source = source.at[r].set(source[i])
    return hi, lo, source, perm

  _, _, _, perm = lax.fori_loop(0, 256, draw, (hi, lo, source, perm))
  return perm


def permutation(seed: Any) -> jnp.ndarray:
  """The permutation table of `opensimplex.OpenSimplex(seed)` (0.3), in JAX.

  opensimplex 0.3 advances a 64-bit LCG (wrapping to a signed 64-bit value,
  `ctypes.c_int64`) three times, then for i = 255..0 advances it once more and
  swaps `source[(seed + 31) % (i + 1)]` (Python's non-negative remainder) into
  `perm[i]`. Only `perm` matters for 4-D noise (the 3-D gradient index table
  is not built).

  Args:
    seed: A Python/numpy integer (any value; taken modulo 2**64, as
      opensimplex's wrapping does), or an integer JAX array (int32 is sign
      extended to 64 bits, uint32 zero extended; int64/uint64 under x64).
      Traceable and vmappable over array seeds (BLE's seeds are int32 in
      [0, 1634753849)).

  Returns:
    int32 array [256] (a permutation of 0..255), `OpenSimplex(seed)._perm`.
  """
  if isinstance(seed, (int, np.integer)):
    hi, lo = _words(int(seed))
    return _permutation_from_words(hi, lo)
  seed = jnp.asarray(seed)
  if not jnp.issubdtype(seed.dtype, jnp.integer):
    raise TypeError(f'seed must be an integer, got {seed.dtype}')
  if seed.dtype.itemsize == 8:
    bits = lax.bitcast_convert_type(seed, jnp.uint64)
    hi = (bits >> 32).astype(jnp.uint32)
    lo = (bits & _MASK32).astype(jnp.uint32)
  elif jnp.issubdtype(seed.dtype, jnp.signedinteger):
    seed = seed.astype(jnp.int32)
    lo = lax.bitcast_convert_type(seed, jnp.uint32)
    hi = jnp.where(seed < 0, np.uint32(_MASK32), np.uint32(0))
  else:
    lo = seed.astype(jnp.uint32)
    hi = jnp.zeros_like(lo)
  return _permutation_from_words(hi, lo)


# ---------------------------------------------------------------------------
# noise4d: which vertices, as a table of opensimplex's rules.
#
# Points are 4-bit masks (bit 0 = x, ..., bit 3 = w) as in opensimplex. The
# kernel takes opensimplex's decisions on the point's in-cell coordinates
# (float comparisons, in the same order on the same values) and packs them
# into a small integer; a table built here once, by applying opensimplex's
# vertex rules in NumPy to every possible decision, gives the region's cube
# vertices and its 3 extra vertices for that integer.
#
# The pentachoron at (1,1,1,1) and the second dispentachoron (in_sum > 2)
# mirror the pentachoron at (0,0,0,0) and the first dispentachoron under
# v -> 1 - v: opensimplex's code for them is the lower regions' code with
# every point complemented, every vertex v replaced by 1 - v, and every
# comparison reversed (< for >, <= for >=, base 3 - in_sum or 4 - in_sum for
# 2 - in_sum or 1 - in_sum). A reversed comparison of scores is the forward
# comparison of their negatives, and negation is exact in IEEE arithmetic
# (-a - b == -(a + b), in_sum - 3 == -(3 - in_sum), bit for bit), so the
# lower regions' decisions taken on the negated scores are opensimplex's
# upper-region decisions, ties included; the table mirrors the vertices.

_PENTACHORON_CODES = 32  # (origin among the closest two) * 16 + a point
_DISPENTACHORON_CODES = 1024  # a + 16 b + 256 a_big + 512 b_big
_MIRROR_CODE = _PENTACHORON_CODES + _DISPENTACHORON_CODES
_SLOTS = 13  # 10 cube vertices (5 used in a pentachoron), 3 extra ones


def _np_bits(c: np.ndarray) -> Tuple[np.ndarray, ...]:
  """(x, y, z, w) bits of points c as booleans, and c & 3."""
  return (c & 1) != 0, (c & 2) != 0, (c & 4) != 0, (c & 8) != 0, c & 3


def _np_vertex(*axes: Any) -> np.ndarray:
  """Vertex coordinates (4 arrays or ints) -> int32 [..., 4]."""
  return np.stack(np.broadcast_arrays(*axes), axis=-1).astype(np.int32)


def _np_minus_one_pair(c: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
  """Two vertices: point c with each 0 replaced by -1, in two ways."""
  x, y, z, w, low = _np_bits(c)
  return (_np_vertex(np.where(x, 1, -1), np.where(y, 1, np.where(x, -1, 0)),
                     np.where(z, 1, np.where(low == 3, -1, 0)),
                     np.where(w, 1, 0)),
          _np_vertex(np.where(x, 1, 0), np.where(y, 1, np.where(x, 0, -1)),
                     np.where(z, 1, np.where(low == 3, 0, -1)),
                     np.where(w, 1, -1)))


def _np_point(c: np.ndarray, scale: int = 1, zero: int = 0) -> np.ndarray:
  """The vertex with `scale` where c's bits are set, else `zero`."""
  return _np_vertex(*(np.where(b, scale, zero) for b in _np_bits(c)[:4]))


def _np_first_set(c: np.ndarray) -> np.ndarray:
  """Point with only the first set bit of c among x, y, z, else w."""
  x, y, z, _, _ = _np_bits(c)
  return np.where(x, 1, np.where(y, 2, np.where(z, 4, 8)))


def _pentachoron_extras(code: np.ndarray) -> np.ndarray:
  """opensimplex's 3 extra vertices in the pentachoron at (0,0,0,0).

  Args:
    code: 16 + the closest point other than the origin where the origin is
      one of the closest two, else the union of the closest two points.

  Returns:
    int32 [..., 3, 4].
  """
  origin_closest, c = code >= 16, code % 16
  x, y, z, w, low = _np_bits(c)
  near = (_np_minus_one_pair(c)[0],
          _np_vertex(np.where(x, 1, 0), np.where(y, 1, np.where(x, 0, -1)),
                     np.where(z, 1, np.where((low != 0) & (low != 3), -1, 0)),
                     np.where(w, 1, 0)),
          _np_vertex(np.where(x, 1, 0), np.where(y, 1, 0),
                     np.where(z, 1, np.where(low == 0, -1, 0)),
                     np.where(w, 1, -1)))
  # Otherwise the extras follow from the union of the closest two.
  far = (_np_point(c), *_np_minus_one_pair(c))
  return np.where(origin_closest[..., None, None], np.stack(near, axis=-2),
                  np.stack(far, axis=-2))


def _dispentachoron_extras(code: np.ndarray) -> np.ndarray:
  """opensimplex's 3 extra vertices in the first dispentachoron.

  Args:
    code: a + 16 b + 256 a_big + 512 b_big: the closest two points a and b
      and whether each is a two-axis point (the bigger side).

  Returns:
    int32 [..., 3, 4].
  """
  a, b = code % 16, code // 16 % 16
  a_big, b_big = (code // 256 % 2) == 1, (code // 512) == 1
  union = a | b
  both_big = (_np_point(union), _np_point(union, 1, -1),
              _np_point(_np_first_set(a & b), 2))
  both_small = (*_np_minus_one_pair(union), np.zeros(a.shape + (4,), np.int32))
  big = np.where(a_big, a, b)
  small = np.where(a_big, b, a)
  one_each = (*_np_minus_one_pair(big), _np_point(_np_first_set(small), 2))
  same = np.where(a_big[..., None, None], np.stack(both_big, axis=-2),
                  np.stack(both_small, axis=-2))
  return np.where((a_big == b_big)[..., None, None], same,
                  np.stack(one_each, axis=-2))


def _vertex_table() -> np.ndarray:
  """The 13 vertex slots of every decision code, packed: int32 [codes, 5].

  Code: _MIRROR_CODE where in_sum > 2, plus the pentachoron's code, or
  _PENTACHORON_CODES + the dispentachoron's code. Word k < 4 holds axis k of
  slot j in bits 2j, 2j + 1 as the coordinate + 1 (-1 to 2); word 4 has bit
  j set where slot j is one of the region's vertices.
  """
  singles = _CUBE[_CUBE_ONES == 1]  # in both lower regions
  pairs = _CUBE[_CUBE_ONES == 2]  # in the dispentachoron; (0,0,0,0) else
  codes = np.arange(_PENTACHORON_CODES + _DISPENTACHORON_CODES)
  middle = codes >= _PENTACHORON_CODES
  extras = np.where(middle[:, None, None],
                    _dispentachoron_extras(codes - _PENTACHORON_CODES),
                    _pentachoron_extras(codes % _PENTACHORON_CODES))
  six = np.where(middle[:, None, None], pairs, 0 * pairs)
  vertices = np.concatenate(
      [np.broadcast_to(singles, (len(codes),) + singles.shape), six, extras],
      axis=1)  # [code, slot, axis]
  vertices = np.concatenate([vertices, 1 - vertices])  # mirrored
  used = np.concatenate([np.ones(4, bool), np.arange(6) == 0,
                         np.ones(3, bool)])
  used = np.where(np.concatenate([middle, middle])[:, None], True, used)
  shifts = 2 * np.arange(_SLOTS)
  words = [((vertices[..., k] + 1) << shifts).sum(axis=1) for k in range(4)]
  words.append((used << np.arange(_SLOTS)).sum(axis=1))
  return np.stack(words, axis=1).astype(np.int32)


_VERTEX_TABLE = _vertex_table()


def _sel(cond: jnp.ndarray, a: Any, b: Any) -> jnp.ndarray:
  """int32 where(cond, a, b)."""
  return jnp.where(cond, a, b).astype(jnp.int32)


def _closest_two(a_score: jnp.ndarray, a_point: jnp.ndarray,
                 b_score: jnp.ndarray, b_point: jnp.ndarray,
                 candidates: Sequence[Tuple[jnp.ndarray, Any]],
                 a_big: Any = None, b_big: Any = None) -> Tuple[Any, ...]:
  """opensimplex's cascade keeping the two highest-scoring of several points.

  For each (score, point) candidate: if a_score >= b_score and the
  candidate's score is greater than b's, it replaces b; elif it is greater
  than a's, it replaces a. A replaced side is flagged as not on the bigger
  side.
  """
  for score, point in candidates:
    keep_a = a_score >= b_score
    to_b = keep_a & (score > b_score)
    to_a = ~keep_a & (score > a_score)
    b_score = jnp.where(to_b, score, b_score)
    b_point = _sel(to_b, point, b_point)
    a_score = jnp.where(to_a, score, a_score)
    a_point = _sel(to_a, point, a_point)
    if a_big is not None:
      b_big = b_big & ~to_b
      a_big = a_big & ~to_a
  return a_score, a_point, b_score, b_point, a_big, b_big


def _pentachoron_code(xins: jnp.ndarray, yins: jnp.ndarray, zins: jnp.ndarray,
                      wins: jnp.ndarray, base: jnp.ndarray) -> jnp.ndarray:
  """opensimplex's decisions in the pentachoron at (0,0,0,0) (in_sum <= 1).

  Args:
    xins: In-cell x coordinate (negated to mirror: see above).
    yins: See xins.
    zins: See xins.
    wins: See xins.
    base: 1 - in_sum, the origin's score (in_sum - 4 to mirror).

  Returns:
    The code of `_pentachoron_extras` (int32).
  """
  ones = jnp.ones(jnp.shape(xins), jnp.int32)
  a_score, a_point, b_score, b_point, _, _ = _closest_two(
      xins, ones * 0x01, yins, ones * 0x02, ((zins, 0x04), (wins, 0x08)))
  origin_closest = (base > a_score) | (base > b_score)
  # (0,0,0,0) is one of the closest two: the other one; else both.
  closest = _sel(b_score > a_score, b_point, a_point)
  return _sel(origin_closest, 16 + closest, a_point | b_point)


def _dispentachoron_code(xins: jnp.ndarray, yins: jnp.ndarray,
                         zins: jnp.ndarray, wins: jnp.ndarray,
                         base: jnp.ndarray) -> jnp.ndarray:
  """opensimplex's decisions in the first dispentachoron (1 < in_sum <= 2).

  Args:
    xins: In-cell x coordinate (negated to mirror: see above).
    yins: See xins.
    zins: See xins.
    wins: See xins.
    base: 2 - in_sum (in_sum - 3 to mirror).

  Returns:
    The code of `_dispentachoron_extras` (int32).
  """
  true = jnp.ones(jnp.shape(xins), bool)
  # Decide between (1,1,0,0) and (0,0,1,1), and (1,0,1,0) and (0,1,0,1).
  cond = xins + yins > zins + wins
  a_score = jnp.where(cond, xins + yins, zins + wins)
  a_point = _sel(cond, 0x03, 0x0C)
  cond = xins + zins > yins + wins
  b_score = jnp.where(cond, xins + zins, yins + wins)
  b_point = _sel(cond, 0x05, 0x0A)
  # The closer of (1,0,0,1) and (0,1,1,0) replaces the further of a and b.
  cond = xins + wins > yins + zins
  score = jnp.where(cond, xins + wins, yins + zins)
  a_score, a_point, b_score, b_point, _, _ = _closest_two(
      a_score, a_point, b_score, b_point, ((score, _sel(cond, 0x09, 0x06)),))
  # Then each single-axis point (on the smaller side).
  candidates = tuple((base + ins, point) for ins, point in
                     zip((xins, yins, zins, wins), (0x01, 0x02, 0x04, 0x08)))
  _, a_point, _, b_point, a_big, b_big = _closest_two(
      a_score, a_point, b_score, b_point, candidates, true, true)
  return (a_point + 16 * b_point + _sel(a_big, 256, 0) +
          _sel(b_big, 512, 0))


def _wrap256(integer_valued: jnp.ndarray) -> jnp.ndarray:
  """Python's `int(v) & 0xFF` of a float holding an integer (exact)."""
  return (integer_valued -
          256 * jnp.floor(integer_valued / 256)).astype(jnp.int32)


def noise4d(perm: jnp.ndarray, x: Any, y: Any, z: Any, w: Any) -> jnp.ndarray:
  """opensimplex 0.3's `OpenSimplex.noise4d(x, y, z, w)`, branch-free JAX.

  Legacy OpenSimplex 4-D noise (Kurt Spencer's algorithm as ported by the
  opensimplex package 0.3): the point is stretched onto the simplectic
  honeycomb, the region of its rhombo-hypercube cell is found from the sum of
  the in-cell coordinates, and the contributions attn**4 * (gradient . d),
  attn = 2 - |d|**2 > 0, of that region's 5 or 10 cube vertices and of 3
  extra vertices (chosen as opensimplex chooses them) are summed and divided
  by 30. Noise coordinates are dimensionless.

  Each point evaluates 13 vertex slots (10 cube vertices, 5 of them masked
  in a pentachoron, and the 3 extra ones), read from `_VERTEX_TABLE` at the
  code of opensimplex's decisions for the point (see the note above
  `_PENTACHORON_CODES`).

  Args:
    perm: int array [256], `permutation(seed)`.
    x: Coordinates (broadcastable arrays or scalars); the computation is
      done in their floating dtype (float64 inside `jax.enable_x64(True)`
      agrees with opensimplex to ~1e-15).
    y: See x.
    z: See x.
    w: See x.

  Returns:
    Noise values (about -1 to 1), of the broadcast shape and floating dtype
    of the coordinates.
  """
  dtype = dtypes.float_dtype(x, y, z, w)
  x, y, z, w = jnp.broadcast_arrays(*(jnp.asarray(v, dtype)
                                      for v in (x, y, z, w)))
  perm = jnp.asarray(perm, jnp.int32)

  # Stretch onto the honeycomb; cell origin; in-cell coordinates. Same
  # operations in the same order as opensimplex: the branch decisions below
  # must see identical values (near-ties are common, e.g. on grids).
  stretch_offset = (x + y + z + w) * STRETCH_CONSTANT_4D
  # The select materialises the rounded product: without it the compiler
  # contracts `x + sum * S` into a fused multiply-add, rounded once where
  # Python rounds twice, which flips near-tie decisions. (A NaN offset only
  # comes from a NaN coordinate, whose noise is NaN either way.)
  stretch_offset = jnp.where(jnp.isnan(stretch_offset), 0, stretch_offset)
  xs, ys, zs, ws = (v + stretch_offset for v in (x, y, z, w))
  xsb, ysb, zsb, wsb = (jnp.floor(v) for v in (xs, ys, zs, ws))
  squish_offset = (xsb + ysb + zsb + wsb) * SQUISH_CONSTANT_4D
  xins, yins, zins, wins = xs - xsb, ys - ysb, zs - zsb, ws - wsb
  in_sum = xins + yins + zins + wins
  d0 = (x - (xsb + squish_offset), y - (ysb + squish_offset),
        z - (zsb + squish_offset), w - (wsb + squish_offset))
  origin = tuple(_wrap256(v) for v in (xsb, ysb, zsb, wsb))

  # Region: pentachoron at (0,0,0,0) (in_sum <= 1), first dispentachoron
  # (<= 2), second dispentachoron (< 3), pentachoron at (1,1,1,1); the
  # upper two are the lower two mirrored. (NaN: upper, middle; noise NaN.)
  upper = ~(in_sum <= 2)
  middle = ~(in_sum <= 1) & ~(in_sum >= 3)
  corner = jnp.where(in_sum <= 1, 1, jnp.where(in_sum >= 3, 4,
                                               jnp.where(upper, 3, 2)))
  corner = corner.astype(dtype)
  # The lower regions' decisions; scores negated where mirrored (exact).
  scores = tuple(jnp.where(upper, -v, v) for v in (xins, yins, zins, wins))
  base = jnp.where(upper, in_sum - corner, corner - in_sum)
  code = jnp.where(middle,
                   _PENTACHORON_CODES + _dispentachoron_code(*scores, base),
                   _pentachoron_code(*scores, base))
  code = code + _sel(upper, _MIRROR_CODE, 0)
  words = jnp.asarray(_VERTEX_TABLE)[code]  # [..., 5]
  # (x, y, z, w) of the 13 vertex slots, int32 [..., 13], and which count.
  shifts = 2 * np.arange(_SLOTS, dtype=np.int32)
  vertices = tuple(((words[..., k, None] >> shifts) & 3) - 1
                   for k in range(4))
  used = ((words[..., 4, None] >> (shifts // 2)) & 1) == 1

  # Contributions of the 13 vertex slots (8 or 13 of them used).
  squish = (vertices[0] + vertices[1] + vertices[2] + vertices[3]).astype(
      dtype) * SQUISH_CONSTANT_4D
  d = [(d0k[..., None] - v.astype(dtype)) - squish
       for d0k, v in zip(d0, vertices)]
  attn = 2 - d[0] * d[0] - d[1] * d[1] - d[2] * d[2] - d[3] * d[3]
  h = perm[(origin[0][..., None] + vertices[0]) & 0xFF]
  for k in (1, 2, 3):
    h = perm[(h + origin[k][..., None] + vertices[k]) & 0xFF]
  row = h >> 2  # GRADIENTS_4D[perm & 0xFC : ... + 4]
  gradients = jnp.asarray(_GRADIENTS_4D.T, dtype)  # [axis, row]
  extrapolation = (gradients[0][row] * d[0] +
                   gradients[1][row] * d[1] +
                   gradients[2][row] * d[2] +
                   gradients[3][row] * d[3])
  attn2 = attn * attn
  contribution = jnp.where(used & (attn > 0), attn2 * attn2 * extrapolation, 0)
  value = contribution.sum(axis=-1) / NORM_CONSTANT_4D
  # opensimplex raises on NaN or infinite coordinates; here they give NaN.
  return jnp.where(jnp.isfinite(in_sum), value, jnp.nan)


# ---------------------------------------------------------------------------
# BLE's noise harmonics (simplex_wind_noise.NoisyWindComponent).

# BLE draws each harmonic's OpenSimplex seed with
# jax.random.choice(key, 1634753849), i.e. an int32 randint in [0, this).
BLE_SEED_RANGE = 1634753849
NOISE_MAGNITUDE = simplex_wind_noise.NOISE_MAGNITUDE  # [m/s] per unit noise

# (weight, x_spacing [km], y_spacing [km], pressure_spacing [Pa],
#  time_spacing [h]) of one harmonic.
Harmonic = Tuple[float, float, float, float, float]


def ble_harmonics(which: str) -> Tuple[Harmonic, ...]:
  """BLE's harmonic constants of the 'u' or 'v' noise component.

  Raises:
    ValueError: if which is not 'u' or 'v'.
  """
  # pylint: disable=protected-access
  table = {'u': simplex_wind_noise._U_COMPONENT_HARMONICS,
           'v': simplex_wind_noise._V_COMPONENT_HARMONICS}
  # pylint: enable=protected-access
  if which not in table:
    raise ValueError(f'Invalid wind component: {which}')
  return tuple((h.weight, h.x_spacing, h.y_spacing, h.pressure_spacing,
                h.time_spacing) for h in table[which])


@flax.struct.dataclass
class NoiseParams:
  """State of one reset BLE noise component (u or v), as a pytree.

  Batch a number of components (e.g. over seeds) by stacking the array
  leaves along a leading axis and `jax.vmap`-ing `wind_noise`.

  Attributes:
    perm: int32 [..., H, 256], each harmonic's `permutation(seed)`.
    offsets: float32 [..., H, 4], each harmonic's random translation of the
      noise grid (x, y, pressure, time), in noise coordinates, float32 as
      BLE's.
    harmonics: Static: H tuples (weight, x_spacing [km], y_spacing [km],
      pressure_spacing [Pa], time_spacing [h]).
  """
  perm: jnp.ndarray
  offsets: jnp.ndarray
  harmonics: Tuple[Harmonic, ...] = flax.struct.field(pytree_node=False)


def reset_noise_params(key: jnp.ndarray, which: str) -> NoiseParams:
  """BLE's `NoisyWindComponent(which).reset(key)`, in JAX (jittable, vmappable).

  Same draws from the same key as BLE 1.0.1: the key is split into one key
  per harmonic; from its key each harmonic draws its OpenSimplex seed with
  `jax.random.choice(key, 1634753849)` (an int32 `randint`) and its offsets
  with `jax.random.uniform(key, (4,)) * 2 - 1` (float32). The dtypes are
  explicit, so the draws are BLE's (made without x64) even inside an x64
  scope.

  Args:
    key: A JAX PRNG key.
    which: 'u' or 'v'.

  Returns:
    The component's NoiseParams.
  """
  harmonics = ble_harmonics(which)
  keys = jax.random.split(key, num=len(harmonics))
  seeds = jax.vmap(lambda k: jax.random.randint(
      k, (), 0, BLE_SEED_RANGE, dtype=jnp.int32))(keys)
  offsets = jax.vmap(lambda k: jax.random.uniform(
      k, (4,), dtype=jnp.float32) * 2.0 - 1.0)(keys)
  return NoiseParams(perm=jax.vmap(permutation)(seeds), offsets=offsets,
                     harmonics=harmonics)


def reset_uv_noise_params(key: jnp.ndarray) -> Tuple[NoiseParams, NoiseParams]:
  """BLE's `wind_field.SimplexWindNoise.reset_wind_noise(key)`: (u, v) params.

  BLE splits the key in two, the first for u and the second for v.
  """
  u_key, v_key = jax.random.split(key, num=2)
  return reset_noise_params(u_key, 'u'), reset_noise_params(v_key, 'v')


def noise_params_from_ble(component: Any) -> NoiseParams:
  """Reads a reset BLE `NoisyWindComponent` (or `FastNoisyWindComponent`).

  Args:
    component: simplex_wind_noise.NoisyWindComponent after `reset(key)`.

  Returns:
    Its NoiseParams (permutation tables, float32 offsets, harmonics).

  Raises:
    ValueError: if the component has not been reset.
  """
  # pylint: disable=protected-access
  perms, offsets, harmonics = [], [], []
  for h in component._harmonics:
    generator = h._simplex_generator
    offset = h._offsets
    if generator is None:
      raise ValueError('Must call reset before reading the noise parameters.')
    perms.append(np.asarray(generator._perm, np.int32))
    offsets.append(np.array([offset.x, offset.y, offset.pressure, offset.time],
                            dtype=np.float32))
    harmonics.append((h.weight, h.x_spacing, h.y_spacing, h.pressure_spacing,
                      h.time_spacing))
  return NoiseParams(perm=jnp.asarray(np.stack(perms)),
                     offsets=jnp.asarray(np.stack(offsets)),
                     harmonics=tuple(harmonics))


def _harmonic_noise(params: Sequence[NoiseParams], points: Sequence[Any],
                    dtype: Any) -> Tuple[jnp.ndarray, ...]:
  """Each component's harmonics' noise4d * NOISE_MAGNITUDE at the points.

  The harmonics of all the components are evaluated in one vectorised
  noise4d call.

  Args:
    params: The components' NoiseParams (leaves [H, ...], no batch axis).
    points: (x [km], y [km], pressure [Pa], time [h]), broadcast, of dtype.
    dtype: The floating dtype of the computation.

  Returns:
    Per component, its noise [m/s] of shape [H, *point shape].
  """
  coordinates = [[] for _ in range(4)]
  for component in params:
    n_harmonics = len(component.harmonics)
    # [harmonic, axis] spacings and offsets, shaped to broadcast over points.
    spacings = np.array([h[1:] for h in component.harmonics],
                        dtype=np.float64)
    spacings = jnp.asarray(spacings, dtype).reshape(
        (n_harmonics, 4) + (1,) * points[0].ndim)
    offsets = jnp.asarray(component.offsets).astype(dtype).reshape(
        spacings.shape)
    for k, point in enumerate(points):
      coordinates[k].append(point / spacings[:, k] + offsets[:, k])
  perm = jnp.concatenate([jnp.asarray(c.perm) for c in params])
  noise = NOISE_MAGNITUDE * jax.vmap(noise4d)(
      perm, *(jnp.concatenate(c) for c in coordinates))
  splits = np.cumsum([len(c.harmonics) for c in params])[:-1]
  return tuple(jnp.split(noise, splits))


def _weighted(noise: jnp.ndarray,
              harmonics: Sequence[Harmonic]) -> jnp.ndarray:
  """BLE's weighted, variance-normalised sum of a component's harmonics."""
  weighted_noise = 0.0
  total_weight = 0.0
  total_weight_squared = 0.0
  for h, harmonic in enumerate(harmonics):
    weight = harmonic[0]
    weighted_noise = weighted_noise + noise[h] * weight
    total_weight += weight
    total_weight_squared += weight**2
  # BLE's variance adjustment (Python floats, as BLE computes them).
  weighted_noise = weighted_noise / total_weight
  return weighted_noise * math.sqrt(total_weight / total_weight_squared)


def _noise_points(*coordinates: Any) -> Tuple[Tuple[jnp.ndarray, ...], Any]:
  """The coordinates, broadcast, in their floating dtype; and that dtype."""
  dtype = dtypes.float_dtype(*coordinates)
  return jnp.broadcast_arrays(*(jnp.asarray(v, dtype)
                                for v in coordinates)), dtype


def wind_noise(params: NoiseParams, x_km: Any, y_km: Any, pressure: Any,
               hours: Any) -> jnp.ndarray:
  """BLE's `NoisyWindComponent.get_noise`: one wind component's noise. # [m/s]

  sum_h NOISE_MAGNITUDE * noise4d(x / x_spacing + offset_x, y / y_spacing +
  offset_y, pressure / pressure_spacing + offset_p, hours / time_spacing +
  offset_t) * weight_h, divided by the total weight and multiplied by
  sqrt(total weight / total squared weight), in BLE's order.

  Computed in the floating dtype of the coordinates (the offsets are BLE's
  float32 values, converted exactly to float64 in x64). For a batch of
  components, `jax.vmap` over params.

  Args:
    params: One component's NoiseParams (leaves [H, ...], no batch axis).
    x_km: Distance east of the station [km] (broadcastable arrays).
    y_km: Distance north of the station [km].
    pressure: Pressure [Pa].
    hours: Time since the start of the wind field [h].

  Returns:
    The noise [m/s], of the coordinates' broadcast shape and dtype.
  """
  points, dtype = _noise_points(x_km, y_km, pressure, hours)
  noise, = _harmonic_noise((params,), points, dtype)
  return _weighted(noise, params.harmonics)


def wind_noise_uv(noise_u: NoiseParams, noise_v: NoiseParams, x_km: Any,
                  y_km: Any, pressure: Any,
                  hours: Any) -> Tuple[jnp.ndarray, jnp.ndarray]:
  """`wind_noise` of the u and v components at the same points. # [m/s]

  The two components' harmonics (BLE's 5 + 5, each with its own constants)
  are evaluated in one vectorised noise4d call: the same values as two
  `wind_noise` calls (the same operations on each harmonic).

  Args:
    noise_u: The eastward component's NoiseParams (no batch axis).
    noise_v: The northward component's NoiseParams.
    x_km: Distance east of the station [km] (broadcastable arrays).
    y_km: Distance north of the station [km].
    pressure: Pressure [Pa].
    hours: Time since the start of the wind field [h].

  Returns:
    (u noise, v noise) [m/s], of the coordinates' broadcast shape and dtype.
  """
  points, dtype = _noise_points(x_km, y_km, pressure, hours)
  u, v = _harmonic_noise((noise_u, noise_v), points, dtype)
  return _weighted(u, noise_u.harmonics), _weighted(v, noise_v.harmonics)
