"""A spread of bond strengths (``model.lattice.weibull_modulus``, ``seed``):
each breakable bond's critical strain is ``break_strain`` times a factor w
drawn from the Weibull distribution of shape m and mean 1,

    P(w <= s) = 1 - exp(-(s / lambda)^m),  lambda = 1 / Gamma(1 + 1/m),

the weakest-link law of brittle strengths (Weibull 1951; the bond strengths of
bonded-particle models, Potyondy & Cundall 2004).  The factor of a bond is a
function of its two particles' global ids and the seed alone (a counter-based
draw: the splitmix64 mix of the pair, inverted through the Weibull CDF), so a
bond gets the same strength on any number of ranks, in any partition and after
a restart, with nothing to store or communicate.
"""
from __future__ import annotations

import math

import numpy as np

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_M1, _M2 = np.uint64(0xBF58476D1CE4E5B9), np.uint64(0x94D049BB133111EB)
_SEED = np.uint64(0xD1B54A32D192ED03)


def uniform(i, j, seed: int) -> np.ndarray:
    """A uniform draw in (0, 1) per pair (i, j) of node ids (symmetric in i, j)."""
    a = np.minimum(i, j).astype(np.uint64)
    b = np.maximum(i, j).astype(np.uint64)
    with np.errstate(over="ignore"):
        x = a * _GOLDEN ^ (b + np.uint64(seed) * _SEED)
        for shift, mult in ((30, _M1), (27, _M2)):          # splitmix64's finaliser
            x ^= x >> np.uint64(shift)
            x *= mult
        x ^= x >> np.uint64(31)
    return ((x >> np.uint64(12)).astype(float) + 0.5) / 2.0 ** 52   # (k + 0.5 exact: < 1)


def weibull(i, j, modulus: float, seed: int) -> np.ndarray:
    """The strength factor w of each bond (i, j): Weibull of shape ``modulus``, mean 1."""
    scale = 1.0 / math.gamma(1.0 + 1.0 / modulus)
    return scale * (-np.log1p(-uniform(i, j, seed))) ** (1.0 / modulus)
