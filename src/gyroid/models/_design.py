"""A linear model's design matrix over a long log, one block of rows at a time.

A 10^7-row log's design matrix is 80 MB per column, and every copy a computation makes of
it (weighting, a QR factor Q, a column deleted) costs as much again. What gyroid needs of
it is small: the R factor of its QR decomposition (p x p) and weighted sums. Both are
accumulated here block by block (TSQR: the R of stacked Rs is the R of the stacked rows),
so that the memory is one block's, whatever the log's length, and the result is the
Householder QR's, not the normal equations' (no squared condition number).
"""

from __future__ import annotations

from collections.abc import Iterator

import jax
import numpy as np

#: Rows per block: 2^18 rows x 8 columns x 8 bytes = 16 MB.
BLOCK_ROWS = 1 << 18


def row_blocks(n: int, rows: int | None = None) -> Iterator[slice]:
    """Consecutive slices of at most ``rows`` (default ``BLOCK_ROWS``) rows covering
    ``range(n)``."""
    rows = rows or BLOCK_ROWS
    for start in range(0, n, rows):
        yield slice(start, min(start + rows, n))


def rows_of(inputs, rows: slice):
    """The same pytree (e.g. :class:`~gyroid.models._inputs.DriftInputs`) restricted to
    ``rows``: every array's leading axis sliced."""
    return jax.tree.map(lambda leaf: leaf[rows], inputs)


def with_rows(r: np.ndarray | None, block: np.ndarray) -> np.ndarray:
    """The R factor of the rows ``r`` stood for (None: no rows yet) and ``block`` below
    them: upper triangular, p x p (fewer rows while there are fewer than p rows). Folded
    over a matrix's blocks it gives ``np.linalg.qr(matrix, mode="r")`` up to row signs."""
    block = np.asarray(block, dtype=float)
    # NumPy's stubs type every mode's result as QRResult; mode "r" returns the R array
    return np.linalg.qr(block if r is None else np.vstack([r, block]), mode="r")  # pyright: ignore[reportReturnType]


def least_squares_from_r(r_augmented: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares coefficients and residual sum of squares of ``y`` on ``X`` from the R
    factor of ``[X, y]`` (p + 1 columns). The minimum-norm solution when ``X`` does not
    have full rank, as ``np.linalg.lstsq(X, y)`` gives."""
    p = r_augmented.shape[1] - 1
    r = np.zeros((p + 1, p + 1))
    r[: r_augmented.shape[0]] = r_augmented
    coefficients, *_ = np.linalg.lstsq(r[:p, :p], r[:p, p], rcond=None)
    rss = float(r[p, p] ** 2 + np.sum((r[:p, :p] @ coefficients - r[:p, p]) ** 2))
    return coefficients, rss
