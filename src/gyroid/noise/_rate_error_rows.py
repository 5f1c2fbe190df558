"""The thermometer's noise through the dT/dt estimator, times wD, as what a noise model carries
on a log's rows (:class:`CarriedThermometer`), and, beside a correlated term, the part of it
the block filter's process cannot carry: the one-sided rows at the log's ends
(:class:`OneSidedRows`). Beside white noise alone the rows' exact covariance is carried
instead (:mod:`gyroid.noise._rate_error_eigenbasis`).

The estimator is linear in the logged temperature, so white thermometer noise gives the rate
an error ``L e`` over the rows (``L`` the estimator as a matrix, ``e`` the noise); times wD
(its least-squares value on the log, fixed for the fit) it adds ``wD^2 v L L'`` to the drift's
noise. Beside a correlated term, in the log's interior the estimator is one kernel and its
error stationary: a process of the block filter carries it
(:mod:`gyroid.noise._rate_error_process`). Within half a
window of either end the window is one-sided and the error is not the interior's (at the
first row some five times its variance, correlated over the window): the process, being
stationary, misses it, and a fit carrying the process alone moved the coefficients a median
0.3-0.5 of their sd from the exact covariance's on paper A's bench with a 0.05 degC
thermometer (``experiments/rate_error_edges.py``).

Those rows' errors are exact here. Each end's rows are slopes of polynomials fitted to the
same window's samples, so their rows of ``L`` span a few dimensions (at most the polynomial's
coefficients: five or six per end): with ``S`` an orthonormal basis of that span (``r`` rows) the
one-sided rows' error is ``A c`` with ``c = S e ~ N(0, I)`` and ``A = L_O S'``, and the other
rows' errors have covariance ``B = L_R S'`` with ``c``. The rows' covariance is then the
process's on the other rows (none on the one-sided ones) plus ``U M U'``, ``U = [[A, 0],
[0, B]]`` and ``M = [[I, I], [I, G]]``: the one-sided rows exact among themselves and with
every other row. That is a covariance where the process holds what ``c`` explains of the
other rows; where it does not, ``G`` inflates their covariance along ``B`` by the least that
makes it one (:func:`_inflation`). ``M`` is indefinite, a correction, not a process; the
rows' innovations under the sum are those of the filter's (``U`` filtered beside the data)
corrected by a second filter whose states are ``c``'s coordinates with prior covariance
``M`` (:meth:`OneSidedRows.innovations`), exact; a marginal needs only their sums, by
Woodbury's identity (:meth:`OneSidedRows.whitened_products`). At a fit's mode on paper A's
bench (20 seeds each, ``experiments/rate_error_edges.py``) the estimates are the exact
covariance's to a median 0.04-0.07 of their sd with a 0.05 degC thermometer and 0.01-0.02
with 0.01 degC.

The cost. Filtered beside the data, ``U``'s ``2r`` columns (20 on paper A's bench) made a warm
default fit of its 10^4-row log 23.4 s where main's single oscillator takes 5.5-6.1 s (one
shared two-core machine, one day). Each end with its own directions and the end's columns
read from their row: 16.4 s. The start's ``V_s c_s`` as states of the first rows (52 of the
1000 block means, left out after), the correction's columns ``[B_s, A_e, B_e]`` (15, the end's
10 read over the last 70 rows): 11.1 s. What is left is the correction's start columns
(five, filtered over every row) and the process's four states: 2000 evaluations of the
marginal in chunks of 500 took 2.9-3.9 s, 1.5-2.0 s without the correction's columns, 1.2 s
on main (timed in turn in one process). So a fit weighs them first
(:mod:`gyroid.bench._one_sided`): where their exact error moves no coefficient by more
than :data:`ONE_SIDED_TOLERANCE` of its sd, the process reads them like every other row.
The rows the early states cover and the row the end's columns start from are what the
widest window of the fit's search needs, and each end's directions are padded to the
estimator's degree (five on paper A's bench at every window from 300 to 2400 s; an end that
spans more keeps its own shape), so that every window's term has one shape: the tour's first fit
(paper A's bench, default noise, a cold cache) compiled 56 s of XLA in 51 programs where
each window's own shapes took 145 s in 53, the BFGS and gradient programs twice; main's
single oscillator 29 s in 40. The whole command took 118.7 s of CPU against 180.7 (main
66.9), warm 34.6 s (main 23.2; one machine, runs in turn beside one study).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from scipy.linalg import solve_triangular

from gyroid.noise._block_filter import block_innovations
from gyroid.noise._rate_error_process import RateErrorProcess

#: A singular value of the one-sided rows' operator below this share of the largest is
#: rounding, not a direction of their error.
_RANK_TOLERANCE = 1e-9
#: The largest shift of any coefficient's estimate, in its sd (rms over the data), allowed
#: for reading the one-sided rows by the interior's process rather than exactly
#: (:func:`coefficient_shift`): a 95 % interval shifted by 0.1 sd holds its value 94.9 % of
#: the time.
ONE_SIDED_TOLERANCE = 0.1


@dataclass(frozen=True)
class CarriedThermometer:
    """The thermometer's noise through dT/dt on a log's rows, times wD, (deg/h)^2, as a
    noise model may carry it: ``operator()`` the rows' error per unit thermometer noise
    (``wD sqrt(v) L``: the error is ``operator() @ e`` for ``e ~ N(0, I)``);
    ``autocovariance()`` the estimator's interior error at lags of one row (None where the
    rows are not evenly spaced for it: a log of bursts); ``one_sided`` the rows whose
    window is one-sided (within half a window of either end); ``white_var`` the rows'
    white variance beside it (what the process is matched against); ``reach`` how many
    first rows read samples the start's one-sided rows read at the widest window of the
    fit's search, and ``directions`` the most each end's error
    spans at any window (:meth:`OneSidedRows.of`: every window's one-sided rows then have
    the same shapes and one compiled program serves the search)."""

    operator: Callable[[], np.ndarray]
    autocovariance: Callable[[], np.ndarray | None]
    one_sided: np.ndarray
    white_var: float
    reach: int | None = None
    directions: int = 0

    def covariance(self) -> np.ndarray:
        """The rows' exact covariance ``wD^2 v L L'``."""
        operator = self.operator()
        return operator @ operator.T


class OneSidedRows(eqx.Module):
    """The one-sided rows' rate error, exact, beside a process carried on the other rows
    (module docstring): ``U M U'`` as constant states the log's first rows read
    (``early``) plus a low-rank correction, ``loadings`` by ``middle``.

    ``U M U' = V V' - B H B'`` with ``V = A + B`` (``A`` and ``B`` have no row in common)
    and ``H = I - G``. Where the two ends' errors share no thermometer sample each end has
    its own directions, and the start's ``V_s c_s`` is read by the first rows only: states
    the filter carries over those rows (``early``: ``V_s`` there) and then leaves out. The
    correction is then ``-B_s H_ss B_s'``, the cross terms ``-B H B'`` between the ends,
    and the end's ``[A_e, B_e]`` in ``[[I, I], [I, I - H_ee]]``: columns ``[B_s, A_e,
    B_e]`` (zero but in the end's last window or so: the filter carries them from the
    first row, zero until then, in the one scan that reads the rest). Where the ends share
    samples (a log shorter than two windows) there is no early part, and the columns are
    ``[A, B]`` in ``[[I, I], [I, G]]``."""

    loadings: Float[Array, "n w"]
    middle: Float[Array, "w w"]
    #: ``V_s`` on the log's first rows (None: no early part).
    early: Float[Array, "m r"] | None
    #: ``G`` (:func:`_inflation`), ``r`` by ``r`` in ``c``'s directions' order.
    inflation: Float[Array, "r r"]
    #: Where ``B``'s columns (``c``'s directions in order) are in ``loadings``.
    explained_at: tuple[int, ...] = eqx.field(static=True)

    @classmethod
    def of(cls, operator: np.ndarray, one_sided: np.ndarray, process: RateErrorProcess, *,
           reach: int | None = None, directions: int = 0) -> OneSidedRows:
        """From the rows' error per unit thermometer noise ``operator`` (rows by noise
        samples), the one-sided rows ``one_sided`` (a boolean mask) and the process carried
        on the other rows (for :func:`_inflation`). ``reach``: the early rows cover at least
        the first ``reach`` rows; ``directions``: each end's directions padded with zero
        ones to as many (a zero direction adds nothing to ``U M U'``): so that a fit's
        windows share their shapes (:class:`CarriedThermometer`)."""
        operator = np.asarray(operator, dtype=float)
        one_sided = np.asarray(one_sided, dtype=bool)
        n = operator.shape[0]
        ends = _ends(operator, one_sided)
        bases = [_padded(_directions(operator[rows], scale), directions)
                 for rows, scale in ends]
        basis = np.concatenate(bases) if bases else np.zeros((0, operator.shape[1]))
        rank = basis.shape[0]
        on_ends = np.zeros((n, rank))
        on_ends[one_sided] = operator[one_sided] @ basis.T
        explained = np.zeros((n, rank))
        explained[~one_sided] = operator[~one_sided] @ basis.T
        inflation = _inflation(explained, one_sided, process)
        start = len(bases[0]) if len(bases) == 2 and len(bases[1]) else 0
        if not start:
            identity = np.eye(rank)
            return cls(jnp.asarray(np.concatenate([on_ends, explained], axis=1)),
                       jnp.asarray(np.block([[identity, identity], [identity, inflation]])),
                       None, jnp.asarray(inflation), tuple(range(rank, 2 * rank)))
        s, e = slice(0, start), slice(start, rank)
        ending = rank - start
        early = on_ends[:, s] + explained[:, s]  # V_s
        # the rows that read V_s (at least the reach's), rounded up to a sixteenth of the
        # rows; the rows beyond read it as zero
        step = max(n // 16, 1)
        reads = int(np.flatnonzero(np.any(early != 0.0, axis=1))[-1]) + 1
        reads = max(reads, reach if reach is not None else 0)
        rows = min(-(-reads // step) * step, n)
        less = np.eye(rank) - inflation  # H
        loadings = np.concatenate([explained[:, s], on_ends[:, e], explained[:, e]], axis=1)
        zero, identity = np.zeros((start, ending)), np.eye(ending)
        middle = np.block([[-less[s, s], zero, -less[s, e]],
                           [zero.T, identity, identity],
                           [-less[e, s], identity, identity - less[e, e]]])
        return cls(jnp.asarray(loadings), jnp.asarray(middle), jnp.asarray(early[:rows]),
                   jnp.asarray(inflation),
                   (*range(start), *range(start + ending, start + 2 * ending)))

    @property
    def explained(self) -> np.ndarray:
        """``B``: the other rows' error's covariance with ``c`` (rows by ``r``)."""
        return np.asarray(self.loadings)[:, list(self.explained_at)]

    def covariance(self) -> np.ndarray:
        """``V_s V_s' + U M U'`` over the rows, (deg/h)^2 (dense)."""
        loadings = np.asarray(self.loadings)
        out = loadings @ np.asarray(self.middle) @ loadings.T
        if self.early is not None:
            early = np.asarray(self.early)
            out[:early.shape[0], :early.shape[0]] += early @ early.T
        return out

    def innovations(self, data, loadings, variance, update) -> tuple[Array, Array]:
        """The innovations and their variances, in time order, under the filter's
        covariance plus ``U M U'``, from the filter's innovations of the data (``data``:
        rows by columns) and of ``U`` (``loadings``) and their variances (``variance``),
        rows with ``update == 0`` predicted through: a filter whose states are ``c``'s
        coordinates, constant, with prior covariance ``M``, each row observing its filtered
        loadings beside its filtered data (independent rows of those variances given the
        states). A marginal needs only their sums (:meth:`whitened_products`)."""
        k = self.middle.shape[0]

        def step(carry, row):
            states, cov = carry  # the states' estimate (per data column) and covariance
            x, u, var, learn = row
            pu = cov @ u
            total = var + u @ pu
            innovation = x - u @ states
            gain = learn * pu / total
            states = states + jnp.outer(gain, innovation)
            cov = cov - learn * jnp.outer(pu, pu) / total
            return (states, cov), (innovation, total)

        start = (jnp.zeros((k, data.shape[1])), self.middle)
        _, (innovation, total) = jax.lax.scan(step, start, (data, loadings, variance, update))
        return innovation, total


    def whitened_products(self, data, loadings) -> tuple[Array, Array, Array]:
        """From the filter's whitened innovations of the data (``data``, rows by columns,
        each row over its sd, held-out rows zero) and of ``U`` (``loadings``, alike): the
        data's cross-products under the rows' whole covariance, by Woodbury's identity
        (``C^-1 = I - u (I + M u'u)^-1 M u'`` in those coordinates), as ``data'data``
        less ``w' inner w``: ``w = u' data`` and ``inner = (I + M u'u)^-1 M`` (symmetric),
        and ``log det(I + M u'u)``, the rows' log-determinant beside the filter's (not a
        number where the sum is no covariance)."""
        k = self.middle.shape[0]
        product = loadings.T @ loadings
        total = jnp.eye(k) + self.middle @ product
        inner = jnp.linalg.solve(total, self.middle)
        sign, log_det = jnp.linalg.slogdet(total)
        return (loadings.T @ data, 0.5 * (inner + inner.T),
                jnp.where(sign > 0, log_det, jnp.nan))


def coefficient_shift(design: np.ndarray, exact: np.ndarray, approximate: np.ndarray,
                      gyro: np.ndarray) -> float:
    """How far the generalised least-squares estimates on the columns ``design`` (rows by
    coefficients) move when the rows' covariance is taken as ``gyro + approximate`` where
    it is ``gyro + exact`` (dense, (deg/h)^2): the largest over the coefficients of the
    difference's rms over the data, in the coefficient's sd under ``gyro + exact``. Exact:
    both estimates are linear in the data, ``A y`` with ``A = (X' C^-1 X)^-1 X' C^-1``, so
    the difference's covariance is ``(A_a - A_e) (gyro + exact) (A_a - A_e)'``."""
    right = np.asarray(gyro) + np.asarray(exact)

    def estimator(covariance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        factor = np.linalg.cholesky(covariance)
        whitened = solve_triangular(factor, design, lower=True)
        precision = whitened.T @ whitened
        weights = solve_triangular(factor, whitened, lower=True, trans=1)  # C^-1 X (1: transposed)
        return np.linalg.solve(precision, weights.T), precision

    on_right, precision = estimator(right)
    difference = estimator(np.asarray(gyro) + np.asarray(approximate))[0] - on_right
    variance = np.einsum("ij,jk,ik->i", difference, right, difference)
    return float(np.max(np.sqrt(variance / np.diag(np.linalg.inv(precision)))))


def _ends(operator: np.ndarray, one_sided: np.ndarray
          ) -> list[tuple[np.ndarray, float]]:
    """The one-sided rows as their ends' (a mask of rows each, and the largest singular
    value over both, the scale of :data:`_RANK_TOLERANCE`): the log's start's and its
    end's apart where their errors share no noise sample (then each end's directions are
    its own), else one set of rows."""
    if not one_sided.any():
        return []
    scale = float(np.linalg.norm(operator[one_sided], 2))
    half = np.arange(one_sided.size) < one_sided.size / 2
    parts = [one_sided & half, one_sided & ~half]
    if all(p.any() for p in parts) and not np.any(
            np.any(operator[parts[0]] != 0.0, axis=0) & np.any(operator[parts[1]] != 0.0,
                                                               axis=0)):
        return [(p, scale) for p in parts]
    return [(one_sided, scale)]


def _directions(ends: np.ndarray, scale: float) -> np.ndarray:
    """An orthonormal basis (rows) of the span of the rows ``ends``, directions whose
    singular value is below :data:`_RANK_TOLERANCE` of ``scale`` left out."""
    support = np.any(ends != 0.0, axis=0)  # the samples they read: exact zeros elsewhere
    _, values, basis = np.linalg.svd(ends[:, support], full_matrices=False)
    kept = basis[values > _RANK_TOLERANCE * max(scale, 1e-300)]
    out = np.zeros((kept.shape[0], ends.shape[1]))
    out[:, support] = kept
    return out


def _padded(basis: np.ndarray, directions: int) -> np.ndarray:
    """``basis`` (rows: directions) with zero rows appended up to ``directions``."""
    missing = max(directions - basis.shape[0], 0)
    return np.concatenate([basis, np.zeros((missing, basis.shape[1]))]) if missing else basis


def _inflation(explained: np.ndarray, one_sided: np.ndarray, process: RateErrorProcess
               ) -> np.ndarray:
    """``G``: the least inflation of the other rows' covariance along ``B`` (``explained``,
    rows by ``r``, zero on the one-sided rows) that makes the carried error a covariance.
    It is zero where the process holds what ``c`` explains of those rows (``P - B B'``
    positive semidefinite); the process, matched to the interior's spectrum, need not (on
    paper A's bench by some 0.3 % of the carried error's largest eigenvalue, enough to
    make a row's innovation variance negative beside a low white level). With ``K = B'
    P^-1 B`` (the process's filter on ``B``'s columns) in its eigenbasis, ``G = V
    diag(max(0, 1 - 1/lam)) V'``: then ``P + B G B' - B B' = P - B H B'`` with ``H = V
    diag(min(1, 1/lam)) V'``, below ``K^-1``, so positive semidefinite, and ``G`` is zero
    in every direction where the process already holds it."""
    n = explained.shape[0]
    learn = (~one_sided).astype(float)
    scale = float(np.max(np.asarray(process.mean_noise), initial=0.0))
    # the process alone on the other rows, a jitter of 1e-9 of a block's own noise beside it
    innovation, variance = block_innovations(
        jnp.asarray(explained), jnp.ones(n), jnp.zeros(n),
        jnp.asarray(np.where(one_sided, 1.0, 1e-9 * max(scale, 1e-300))), [], 0.0,
        jnp.asarray(learn), centred=False, rate_error=process)
    whitened = np.asarray(innovation) * np.sqrt(learn / np.asarray(variance))[:, None]
    values, vectors = np.linalg.eigh(whitened.T @ whitened)
    shrink = np.where(values > 1.0, 1.0 - 1.0 / np.maximum(values, 1.0), 0.0)
    return (vectors * shrink) @ vectors.T
