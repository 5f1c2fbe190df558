"""The thermometer's noise through the dT/dt estimator beside white noise alone: the rows'
exact covariance ``M = wD^2 v L L'`` (:class:`~gyroid.noise._rate_error_rows.
CarriedThermometer`) in one eigenbasis (:class:`RowEigenbasis`).

Beside white noise ``s^2 D0`` alone (``D0``: a row's variance per unit level,
``row_scale^2``, or each row's own when the log gives it, ``s = 1``) the rows' covariance
``s^2 D0 + M`` is diagonal in one basis for every ``s``: with ``D0^-1/2 M D0^-1/2 = V
diag(lam) V'`` and ``W = V' D0^-1/2``, ``r' C^-1 r = sum (W r)^2 / (s^2 + lam)`` and ``log
det C = sum log D0 + sum log(s^2 + lam)``. The coordinates ``W r`` are the innovations a
filter would give (exact, O(n^2) per evaluation, one eigendecomposition per fit), so the
coefficients integrate out of this likelihood as out of any filter's
(:mod:`gyroid.inference._collapsed`). The process a correlated term carries it by
(:mod:`gyroid.noise._rate_error_process`) cannot stand in for it here: the
white level is read where the rate error's spectrum falls below it, and where the rate
error dominates the rows (the simulation-based calibration's thermal bench, 20 s block
means, a 1200 s window, |wD| above 9 deg/h per degC/h) the process moved the white level's
mode by 1.2 of its sd (rms over 15 logs) from the exact covariance's, and a match held to
the white level's Whittle score at a white level read on least-squares residuals by 1.0
(``experiments/sbc.py``: the process's 90 % intervals held the level 81.5 % of the time).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

_LOG_2PI = math.log(2.0 * math.pi)


class RowEigenbasis(eqx.Module):
    """The rows' covariance ``s^2 D0 + M`` in the eigenbasis of ``D0^-1/2 M D0^-1/2`` over
    the rows kept (module docstring). Each kept row's position holds one coordinate (an
    eigenvector, ``basis`` row, and its eigenvalue ``lam``); a held-out row's position holds
    none (``on`` 0), so that the rows' weights mask the coordinates. Every coordinate is
    scaled by the kept rows' geometric mean of ``D0`` so that the coordinates' variances
    carry ``log det D0`` between them."""

    covariance: Float[Array, "n n"]  # M, (deg/h)^2
    d0: Float[Array, " n"]
    basis: Float[Array, "n n"]
    lam: Float[Array, " n"]
    on: Float[Array, " n"]
    log_scale: Float[Array, ""]  # the kept rows' mean log D0

    @classmethod
    def of(cls, covariance: np.ndarray, d0: np.ndarray, keep: np.ndarray) -> RowEigenbasis:
        """The eigenbasis of ``covariance`` (M) over the white part ``d0`` on the rows
        ``keep`` (a boolean mask)."""
        covariance, d0 = np.asarray(covariance, dtype=float), np.asarray(d0, dtype=float)
        keep = np.asarray(keep, dtype=bool)
        root = 1.0 / np.sqrt(d0[keep])
        lam, vectors = np.linalg.eigh(root[:, None] * covariance[np.ix_(keep, keep)]
                                      * root[None, :])
        n = d0.size
        basis, lam_rows = np.zeros((n, n)), np.zeros(n)
        kept = np.flatnonzero(keep)
        basis[np.ix_(kept, kept)] = vectors.T * root[None, :]
        lam_rows[kept] = np.maximum(lam, 0.0)
        return cls(jnp.asarray(covariance), jnp.asarray(d0), jnp.asarray(basis),
                   jnp.asarray(lam_rows), jnp.asarray(keep, dtype=float),
                   jnp.asarray(float(np.mean(np.log(d0[keep])))))

    def on_rows(self, keep: np.ndarray) -> RowEigenbasis:
        """The same covariance's eigenbasis over the rows ``keep`` (a boolean mask)."""
        return RowEigenbasis.of(np.asarray(self.covariance), np.asarray(self.d0), keep)

    def _level(self, white) -> Array:
        """``s^2`` from the white sd a filter is given (a row's, or each row's): ``white^2 /
        D0`` is the same on every row."""
        ratio = jnp.broadcast_to(jnp.asarray(white) ** 2, self.d0.shape) / self.d0
        return jnp.sum(self.on * ratio) / jnp.sum(self.on)

    def innovations(self, observed, white) -> tuple[Array, Array]:
        """The coordinates of ``observed`` (rows; trailing columns alike) and their
        variances at the white sd ``white``: independent, as a filter's innovations."""
        scale = jnp.exp(self.log_scale)
        return (jnp.sqrt(scale) * (self.basis @ observed),
                scale * (self._level(white) + self.lam))

    def leave_one_out_rows(self, innovation, variance) -> Array:
        """Each row's density given every other row, from :meth:`innovations` of its
        residual (Burkner, Gabry & Vehtari 2021, for non-factorised normal models): with
        ``g = C^-1 r`` and ``c = diag(C^-1)``, ``-0.5 log 2pi + 0.5 log c_i - 0.5 g_i^2 /
        c_i``; 0 for a row held out."""
        scale = jnp.exp(self.log_scale)
        inverse = self.on / (variance / scale)
        g = self.basis.T @ (innovation / jnp.sqrt(scale) * inverse)
        c = (self.basis**2).T @ inverse
        safe = jnp.where(c > 0, c, 1.0)
        rows = -0.5 * _LOG_2PI + 0.5 * jnp.log(safe) - 0.5 * g**2 / safe
        return jnp.where(c > 0, rows, 0.0)

    def standardised(self, residual, white) -> Array:
        """The residual's sequential innovations over their sds (time-ordered, by the
        Cholesky factor of ``s^2 D0 + M``): independent N(0, 1) where the model is right."""
        covariance = jnp.diag(self._level(white) * self.d0) + self.covariance
        return jax.scipy.linalg.solve_triangular(jnp.linalg.cholesky(covariance), residual,
                                                 lower=True)
