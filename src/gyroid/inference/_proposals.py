"""Importance-sampling proposals (:mod:`gyroid.inference._importance`): mixtures of
multivariate Student-t's, each able to draw and to give its log-density at many points."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy import special


def _t_log_kernel(squared: np.ndarray, df: float, d: int, log_det: float) -> np.ndarray:
    """log-density of a d-variate Student-t at whitened squared distances ``squared``."""
    const = (special.gammaln(0.5 * (df + d)) - special.gammaln(0.5 * df)
             - 0.5 * d * math.log(df * math.pi) - 0.5 * log_det)
    return const - 0.5 * (df + d) * np.log1p(squared / df)


def _t_draws(rng: np.random.Generator, n: int, factor: np.ndarray, df: float) -> np.ndarray:
    """``n`` draws of a centred Student-t whose scale matrix has Cholesky factor ``factor``."""
    z = rng.standard_normal((n, factor.shape[0]))
    return (z / np.sqrt(rng.chisquare(df, n) / df)[:, None]) @ factor.T


@dataclass(frozen=True)
class StudentMixture:
    """Student-t's of one degree of freedom ``df``, each its own weight, location and scale
    matrix (rows of ``locations``, ``factors`` their Cholesky factors)."""

    weights: np.ndarray
    locations: np.ndarray
    factors: np.ndarray
    df: float

    @classmethod
    def of(cls, components: list[tuple[float, np.ndarray, np.ndarray]], df: float
           ) -> StudentMixture:
        """From (weight, location, scale matrix); ``LinAlgError`` when a scale matrix is
        not positive definite."""
        weights = np.array([w for w, _, _ in components], dtype=float)
        return cls(weights / weights.sum(), np.array([m for _, m, _ in components]),
                   np.array([np.linalg.cholesky(c) for _, _, c in components]), df)

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        which = rng.choice(self.weights.size, size=n, p=self.weights)
        out = np.empty((n, self.locations.shape[1]))
        for j in np.unique(which):
            rows = which == j
            out[rows] = self.locations[j] + _t_draws(rng, int(rows.sum()), self.factors[j],
                                                     self.df)
        return out

    def log_pdf(self, x: np.ndarray) -> np.ndarray:
        d = x.shape[1]
        parts = []
        for w, m, f in zip(self.weights, self.locations, self.factors, strict=True):
            z = scipy.linalg.solve_triangular(f, (x - m).T, lower=True)
            log_det = 2.0 * float(np.sum(np.log(np.diag(f))))
            parts.append(math.log(w) + _t_log_kernel(np.sum(z**2, axis=0), self.df, d,
                                                     log_det))
        return np.logaddexp.reduce(parts, axis=0)


@dataclass(frozen=True)
class Kernels:
    """An equal mixture of Student-t's about ``centres`` sharing one scale matrix (Cholesky
    factor ``factor``): a kernel density estimate that can be drawn from."""

    centres: np.ndarray
    factor: np.ndarray
    df: float

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return (self.centres[rng.integers(self.centres.shape[0], size=n)]
                + _t_draws(rng, n, self.factor, self.df))

    def log_pdf(self, x: np.ndarray) -> np.ndarray:
        whiten = scipy.linalg.solve_triangular
        zx = whiten(self.factor, x.T, lower=True).T
        zc = whiten(self.factor, self.centres.T, lower=True).T
        squared = np.maximum(np.sum(zx**2, axis=1)[:, None] + np.sum(zc**2, axis=1)[None, :]
                             - 2.0 * zx @ zc.T, 0.0)
        log_det = 2.0 * float(np.sum(np.log(np.diag(self.factor))))
        return (special.logsumexp(_t_log_kernel(squared, self.df, x.shape[1], log_det),
                                  axis=1) - math.log(self.centres.shape[0]))


@dataclass(frozen=True)
class Blend:
    """Proposals mixed in the proportions ``weights``."""

    weights: tuple[float, ...]
    parts: tuple

    def draw(self, n: int, rng: np.random.Generator) -> np.ndarray:
        counts = rng.multinomial(n, np.asarray(self.weights) / sum(self.weights))
        return np.concatenate([part.draw(int(m), rng)
                               for part, m in zip(self.parts, counts, strict=True) if m])

    def log_pdf(self, x: np.ndarray) -> np.ndarray:
        total = sum(self.weights)
        return np.logaddexp.reduce([math.log(w / total) + part.log_pdf(x)
                                    for w, part in zip(self.weights, self.parts, strict=True)],
                                   axis=0)
