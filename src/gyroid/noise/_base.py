"""What a noise model reads of a log's rows (:class:`RowClock`), the covariance of parts'
means from the rows' (:func:`parts_mean_covariance`), and a level for predicting new data
from its posterior (:func:`predictive_level`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from jax.typing import ArrayLike
from jaxtyping import Array, Float


@dataclass(frozen=True)
class RowClock:
    """Where a log's rows sit in time, as a filter reads them: ``steps_s`` the time since
    the previous row (the first: the median step), ``step_s`` that median, ``gap_s`` for
    rows that are means over one step (block means) the pause before each (else None),
    ``weight`` 1 for a row learnt from and 0 for one predicted through (None: all)."""

    steps_s: Float[Array, " n"]
    step_s: float | Array
    gap_s: Float[Array, " n"] | None = None
    weight: Float[Array, " n"] | None = None


def parts_mean_covariance(row_covariance: ArrayLike, part: np.ndarray, n_parts: int
                          ) -> np.ndarray:
    """The covariance of parts' means given the rows' covariance ``row_covariance``
    (``part``: each row's part, -1 for none): ``A C A'``, ``A`` averaging each part's
    rows."""
    rows = np.asarray(part)
    kept = rows >= 0
    counts = np.bincount(rows[kept], minlength=n_parts).astype(float)
    average = np.zeros((n_parts, rows.size))
    average[rows[kept], np.flatnonzero(kept)] = 1.0 / counts[rows[kept]]
    return average @ np.asarray(row_covariance) @ average.T


def predictive_level(summary: Mapping) -> float:
    """A noise level for predicting new data from its posterior ``summary`` (``mean`` and,
    from a posterior, ``sd``): the root mean square ``sqrt(mean^2 + sd^2)``. Every noise
    covariance is linear in the squares of its levels, so the predictive variance averaged
    over the posterior is the covariance at these; at the posterior mean instead, a level the
    log barely resolves (a walk's K known to within its own size) would be taken as known,
    and a new run's bands drawn too narrow (a FOG's second run held 58-85 % of its
    10-minute means in them)."""
    mean = float(summary["mean"])
    sd = float(summary.get("sd") or 0.0)
    return math.sqrt(mean**2 + sd**2)
