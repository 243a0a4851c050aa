"""Load factors in time: a ramp, a pulse, a table, and the factors of several load groups.

Each function is a callable t -> lambda(t) for :class:`flexbody.dynamics.DynamicModel` (``load_factor``);
:class:`GroupFactors` gives one factor per load group of a Model (``Model.load_groups``), so that loads
follow their own histories: r = M vdot + f_int - sum_k lambda_k(t) f_ext,k - f_g.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Callable

import numpy as np


def _finite(value, name: str, *, positive: bool = False, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonnegative and value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Ramp:
    """lambda(t) = min(t / time, 1): a linear rise to 1 over ``time``, then held."""

    time: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "time", _finite(self.time, "ramp time", positive=True))

    def __call__(self, t: float) -> float:
        return min(max(t, 0.0) / self.time, 1.0)


@dataclass(frozen=True)
class Pulse:
    """A pulse of height 1 from ``start`` to ``start + duration``, zero outside.

    shape "sin2": lambda = sin^2(pi (t - start) / duration) (smooth, starts and ends with zero slope);
    "rect": lambda = 1 on [start, start + duration).
    """

    start: float
    duration: float
    shape: str = "sin2"

    SHAPES = ("sin2", "rect")

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", _finite(self.start, "pulse start", nonnegative=True))
        object.__setattr__(self, "duration", _finite(self.duration, "pulse duration", positive=True))
        if self.shape not in self.SHAPES:
            raise ValueError(f"pulse shape must be one of {', '.join(map(repr, self.SHAPES))}, got {self.shape!r}")

    def __call__(self, t: float) -> float:
        s = (t - self.start) / self.duration
        if not 0.0 <= s < 1.0:
            return 0.0
        return 1.0 if self.shape == "rect" else math.sin(math.pi * s) ** 2


@dataclass(frozen=True, eq=False)
class Table:
    """lambda(t) interpolated linearly in a table (times increasing), held at its first and last values."""

    times: np.ndarray
    values: np.ndarray

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
            raise ValueError(f"table times must be a non-empty list of finite numbers, got {self.times!r}")
        if v.shape != t.shape or not np.all(np.isfinite(v)):
            raise ValueError(f"table values must be {t.size} finite numbers (one per time), got {self.values!r}")
        if np.any(np.diff(t) <= 0):
            raise ValueError(f"table times must be increasing, got {t.tolist()}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "values", v)

    def __call__(self, t: float) -> float:
        return float(np.interp(t, self.times, self.values))


def constant(t: float) -> float:
    """lambda(t) = 1."""
    return 1.0


@dataclass(frozen=True, eq=False)
class GroupFactors:
    """t -> (lambda_0(t), ..., lambda_{G-1}(t)): the factors of a Model's load groups."""

    functions: tuple[Callable[[float], float], ...]

    def __call__(self, t: float) -> np.ndarray:
        return np.array([f(t) for f in self.functions], dtype=float)
