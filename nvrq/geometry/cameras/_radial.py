"""Monotonic 1D maps (distortion polynomials) and their vectorised inverses.

Layer: nvrq core, geometry.

Every distorted model here has a radial function ``y = f(x)`` (angle -> pixel distance,
undistorted -> distorted radius, ...). It is only usable where it is strictly increasing:
past its first maximum (or a pole) two different rays map to the same radius and points
far outside the field of view fold back into the image. :class:`MonotonicMap` finds that
limit once per camera by dense sampling and inverts ``f`` below it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["MonotonicMap", "horner", "poly_derivative"]

_UNIFORM = 4097

Fn = Callable[[np.ndarray], np.ndarray]


def horner(coeffs: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``sum_i coeffs[i] * x**i`` (ascending coefficients), same shape as ``x``.

    Parameters
    ----------
    coeffs : (D,) float64
        Polynomial coefficients, ascending.
    x : ndarray
        Points, any shape.

    Returns
    -------
    ndarray of float64
        Same shape as ``x``.

    >>> horner(np.array([1.0, 2.0, 3.0]), np.array([0.0, 2.0])).tolist()
    [1.0, 17.0]
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.zeros_like(x)
    for c in coeffs[::-1]:
        y = y * x + c
    return y


def poly_derivative(coeffs: np.ndarray) -> np.ndarray:
    """Ascending coefficients of the derivative: ``[c1, 2 c2, 3 c3, ...]``.

    Parameters
    ----------
    coeffs : (D,) float64
        Polynomial coefficients, ascending.

    Returns
    -------
    (D - 1,) float64
        The derivative's coefficients, ascending.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    return coeffs[1:] * np.arange(1, len(coeffs))


class MonotonicMap:
    """``y = f(x)`` on ``[0, x_lim]``, where ``x_lim`` ends the range where ``f`` increases.

    ``grid``: ``(M,)`` increasing samples of the candidate domain, ``grid[0] == 0``.
    ``x_lim`` is found once, numerically: the first sample where ``df <= 0`` (or ``ok`` is
    False, e.g. a vanishing denominator) is located, then the boundary is bisected between
    it and the previous sample (60 halvings); ``x_lim`` is the last point known to be good.
    If every sample is good, ``x_lim = grid[-1]``. A dip narrower than the sample spacing
    could be missed; the grids used are ~20,000 samples over the whole domain.

    The inverse starts from linear interpolation in a table uniform in ``y`` (4097 entries
    over ``[y0, min(y_lim, lookup_max)]``, built once; larger ``y`` fall back to a search in
    the dense samples) and polishes with vectorised Newton steps (at most ``iterations``,
    stopping early when every step is below ``1e-13 * (1 + |x|)``).

    Parameters
    ----------
    f, df : callable
        The map and its derivative, vectorised over arrays.
    grid : (M,) float64
        Increasing samples of the candidate domain, ``grid[0] == 0``.
    ok : callable, optional
        ``ok(x) -> bool array``: False where the map is unusable (e.g. a vanishing
        denominator).
    lookup_max : float, optional
        Upper end of the uniform-in-``y`` inverse table (default: ``y_lim``).
    """

    def __init__(
        self,
        f: Fn,
        df: Fn,
        grid: np.ndarray,
        *,
        ok: Fn | None = None,
        lookup_max: float | None = None,
    ):
        self.f, self.df = f, df
        grid = np.asarray(grid, dtype=np.float64)

        def good(x: np.ndarray) -> np.ndarray:
            res = df(x) > 0
            return res & ok(x) if ok is not None else res

        bad = np.flatnonzero(~good(grid))
        if bad.size == 0:
            x_lim = float(grid[-1])
        elif bad[0] == 0:
            x_lim = 0.0
        else:
            lo, hi = float(grid[bad[0] - 1]), float(grid[bad[0]])
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if good(np.array([mid]))[0]:
                    lo = mid
                else:
                    hi = mid
            x_lim = lo
        self.x_lim = x_lim
        table_x = np.append(grid[grid < x_lim], x_lim)
        self._tx, self._ty = table_x, f(table_x)
        self.y0 = float(self._ty[0])
        self.y_lim = float(self._ty[-1])
        # lookup table uniform in y: 4097 values, inverted from the sampled table
        self._u_max = self.y_lim if lookup_max is None else min(self.y_lim, float(lookup_max))
        uy = np.linspace(self.y0, self._u_max, _UNIFORM)
        self._ux = self._newton(np.interp(uy, self._ty, self._tx), uy, 30)
        span = self._u_max - self.y0
        self._uy_scale = (_UNIFORM - 1) / span if span > 0 else 0.0

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return self.f(x)

    def inverse(self, y: np.ndarray, *, iterations: int = 60) -> np.ndarray:
        """``x`` with ``f(x) == y`` for ``y0 <= y <= y_lim``; NaN elsewhere. Same shape as ``y``.

        Newton converges quadratically except next to a maximum of ``f`` (where it is
        linear), hence the generous cap; only unconverged entries are iterated.
        """
        y = np.asarray(y, dtype=np.float64)
        yf = y.ravel()
        x = self._newton(self._lookup(yf), yf, iterations)
        slack = 4 * np.finfo(np.float64).eps * abs(self.y_lim)  # rounding at the fold
        return np.where((y >= self.y0) & (y <= self.y_lim + slack), x.reshape(y.shape), np.nan)

    def _lookup(self, y: np.ndarray) -> np.ndarray:
        """Starting guess: linear interpolation in a table uniform in ``y`` (no search)."""
        t = (y - self.y0) * self._uy_scale
        t = np.clip(np.where(np.isfinite(t), t, 0.0), 0.0, _UNIFORM - 1)
        i = np.minimum(t.astype(np.intp), _UNIFORM - 2)
        x0 = self._ux[i]
        x = x0 + (t - i) * (self._ux[i + 1] - x0)
        beyond = np.flatnonzero(y > self._u_max)
        if beyond.size:
            x[beyond] = np.interp(y[beyond], self._ty, self._tx)
        return x

    def _newton(self, x: np.ndarray, y: np.ndarray, iterations: int) -> np.ndarray:
        """Polish ``f(x) == y`` in place on flat arrays; only unconverged entries are stepped."""
        active = np.flatnonzero(np.isfinite(y))
        with np.errstate(all="ignore"):
            for _ in range(iterations):
                if active.size == 0:
                    break
                xa, ya = x[active], y[active]
                step = (self.f(xa) - ya) / self.df(xa)
                xa = np.clip(xa - step, 0.0, self.x_lim)
                x[active] = xa
                active = active[np.abs(step) > 1e-13 * (1.0 + np.abs(xa))]
        return x
