"""The one block filter of a drift log's correlated noise: the exact Gaussian likelihood of
means of blocks of samples under white noise plus stationary Gauss-Markov processes plus a
rate random walk plus (optionally) the thermometer's error through dT/dt, by a Kalman filter
whose states the noise model's terms supply (:mod:`gyroid.noise._terms`).

IEEE Std 952's rate noise is this filter's main use: white (angle random walk ``N``),
flicker (bias instability ``B``) and rate random walk (``K``). Units: ``N`` in deg/sqrt(h)
(white rate noise of two-sided density ``60 N`` deg/h sqrt(s)), ``B`` in deg/h (flicker of
two-sided density ``B**2 / (2 pi f)``, Allan floor ``0.664 B``), ``K`` in deg/h/sqrt(h) (a
rate random walk diffusing ``(K / 60)**2`` (deg/h)^2 per second).

The random walk has no anchor at the first row: its level there is diffuse (unknown, with
no prior), and the walk is constrained to average zero over the log's blocks (each weighted
by its span), so that a drift model's bias ``w0`` is the bias over the log, not at its
start. A walk anchored at zero at the first row made ``w0`` the bias of the log's first
minutes, with an interval that did not describe the log (issue 42: a real 74 h thermal log).
The filter starts the diffuse level exactly (Durbin & Koopman's exact initial filter: the
first observed block reveals it), accumulates the walk's weighted mean as a state, and ends
with that mean observed as zero; the constraint's innovation takes the first observed row's
place, so the ``n`` innovations are the exact likelihood of the centred walk. Without a walk
term the walk's state stays at zero (``centred=False``). The Gauss-Markov processes are
stationary (``w0`` is their long-run mean).

Each observation is the mean of a block ``k`` of the log: its time span ``L_k`` (s, the
samples' count times the sampling step) follows a gap ``g_k`` (s) after the previous block.
The white part of a mean has variance ``(60 N)**2 / L_k`` (or the block's known variance).
Flicker is a sum of ``J`` first-order Gauss-Markov (Ornstein-Uhlenbeck) processes with
correlation times spaced evenly in ``log tau`` by a ratio ``r`` from a quarter of the
shortest block to four times the log's length, each of variance ``B**2 ln(r) / pi``:
their summed spectrum is ``B**2 / (2 pi f)`` within a few per cent across that band (a
classic construction, checked in the tests); a Gauss-Markov bias is one more such process
with its own variance. For each process the block's mean and the state at its end are
jointly Gaussian given the state at the previous block's end, with the exact integrals of
the process over the gap and the block, so the filter's innovations give the exact Gaussian
likelihood of the block means, for blocks of any lengths and gaps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import pairwise

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.noise._rate_error_process import RateErrorProcess

#: Gauss-Markov processes summed into the flicker.
FLICKER_PROCESSES = 6
#: A group of stationary Gauss-Markov processes: their correlation times (s), a level
#: (deg/h) and each one's variance per unit level squared (the flicker's ``B`` and
#: ``ln(r) / pi``; a bias's sd and 1).
Processes = tuple[Float[Array, " j"] | np.ndarray, Float[Array, ""] | float, float]


def flicker_times(shortest_s: float, duration_s: float) -> tuple[np.ndarray, float]:
    """The flicker's correlation times (s), evenly spaced in log from a quarter of the
    shortest block to four times the log's length, and the variance of each per unit
    ``B**2`` ((deg/h)^2 per (deg/h)^2): ``ln(r) / pi`` for spacing ratio ``r``."""
    low = max(shortest_s, 1e-9) / 4.0
    high = max(4.0 * duration_s, 64.0 * low)
    times = np.geomspace(low, high, FLICKER_PROCESSES)
    return times, math.log(times[1] / times[0]) / math.pi


def _integral_variance(u):
    """``2u - 3 + 4 exp(-u) - exp(-2u)`` (the variance of a unit Gauss-Markov process's
    integral over ``u`` correlation times, per tau^2), with its series below ``u = 0.01``
    where the closed form cancels."""
    small = u < 0.01
    us = jnp.where(small, u, 0.01)
    series = us**3 * (2.0 / 3.0 - us / 2.0 + 7.0 * us**2 / 30.0 - us**3 / 12.0)
    ul = jnp.where(small, 1.0, u)
    closed = 2.0 * ul - 3.0 + 4.0 * jnp.exp(-ul) - jnp.exp(-2.0 * ul)
    return jnp.where(small, series, closed)


def block_transitions(span_s, gap_s, tau_s, variance, diffusion):
    """Per block (leading axis) and process (trailing axis: the flicker's, then the random
    walk): ``phi`` (state at the block's end per state at the previous end), ``c`` (the
    block mean per previous state), and the new noise's variances and covariance of the
    state ``qxx``, of the mean ``qmm``, and between them ``qxm``."""
    L, g = span_s[:, None], gap_s[:, None]
    u, v = L / tau_s, g / tau_s
    phi_l, phi_g = jnp.exp(-u), jnp.exp(-v)
    lost_g = -jnp.expm1(-2.0 * v)  # 1 - phi_g^2
    c_l = -jnp.expm1(-u) / u  # mean over the block per state at its start
    own = variance * tau_s**2 * _integral_variance(u) / L**2
    phi = jnp.concatenate([phi_l * phi_g, jnp.ones_like(L)], axis=1)
    c = jnp.concatenate([c_l * phi_g, jnp.ones_like(L)], axis=1)
    qxx = jnp.concatenate([variance * -jnp.expm1(-2.0 * (u + v)), diffusion * (g + L)], axis=1)
    qmm = jnp.concatenate([c_l**2 * variance * lost_g + own, diffusion * (g + L / 3.0)],
                          axis=1)
    qxm = jnp.concatenate([phi_l * c_l * variance * lost_g
                           + variance * tau_s * jnp.expm1(-u) ** 2 / L,
                           diffusion * (g + L / 2.0)], axis=1)
    return phi, c, qxx, qmm, qxm


@eqx.filter_jit
def block_innovations(
    observed: Float[Array, "n ..."],
    span_s: Float[Array, " n"],
    gap_s: Float[Array, " n"],
    white_var: Float[Array, " n"],
    processes: Sequence[Processes],
    diffusion: Float[Array, ""] | float,
    update: Float[Array, " n"] | None = None,
    centred: bool = True,
    rate_error: RateErrorProcess | None = None,
    early: Float[Array, "m r"] | None = None,
) -> tuple[Float[Array, "n ..."], Float[Array, " n"]]:
    """Innovations of the block means ``observed`` (trailing columns filtered alike) and
    their variances, under white noise of per-block variance ``white_var`` ((deg/h)^2) plus
    stationary Gauss-Markov processes (``processes``: groups, :data:`Processes`; the
    flicker's, a bias's) plus a rate random walk
    diffusing ``diffusion`` ((deg/h)^2 per s: ``(K / 60)**2``), plus ``rate_error``: the
    thermometer's noise through the dT/dt estimator
    (:mod:`gyroid.noise._rate_error_process`, set up on these blocks), or None. Rows with
    ``update == 0`` are predicted through, not learnt from.

    ``centred``: the walk diffuse at the start and averaging zero over the blocks (module
    docstring); the first row learnt from then carries the constraint's innovation.
    ``centred=False``: the walk from zero at the first block (for a model without a walk,
    whose filter needs no diffuse start).

    A carried rate error's one-sided rows (:class:`~gyroid.noise._rate_error_rows.
    OneSidedRows`), exactly: their loadings are trailing columns of ``observed``, filtered
    alike from the first row (the end's are zero, and so their innovations, until its last
    window: one scan, one compiled shape); ``early`` (``m`` by ``r``): ``r`` constant
    standard-normal states read through these loadings by the first ``m`` rows, filtered
    there and left out after (their own scan: carried over every row, a warm fit took
    1.7x as long)."""
    tau_s = jnp.concatenate([jnp.zeros(0), *(p[0] for p in processes)])
    phi, c, qxx, qmm, qxm = block_transitions(span_s, gap_s, tau_s, 1.0, 1.0)
    j = tau_s.size
    variances = [level**2 * unit for _, level, unit in processes]
    r, first = white_var, 0
    for (taus, _, _), variance in zip(processes, variances, strict=True):
        r = r + variance * jnp.sum(qmm[:, first:first + taus.size], axis=1)
        first += taus.size
    r = r + diffusion * qmm[:, j]
    update = jnp.ones_like(span_s) if update is None else update

    def per_state():  # each process state's variance (built twice: see below)
        return [jnp.full((p[0].size,), v) for p, v in zip(processes, variances, strict=True)]

    # the start's and the new noise's scale built apart: one shared array would sum their
    # gradients in another order (1 ulp), and refactors are checked bit for bit
    start_var = jnp.concatenate([*per_state(), jnp.zeros(1)])
    scale = jnp.concatenate([*per_state(), jnp.full((1,), diffusion)])
    link, q_link = None, None  # the running mean's transition entry and state noise
    if centred:
        # the walk's running weighted mean over the log: each block's share of it times
        # the walk's block mean (module docstring)
        weight = span_s / jnp.sum(span_s)
        phi = jnp.concatenate([phi, jnp.ones_like(weight)[:, None]], axis=1)
        c = jnp.concatenate([c, jnp.zeros_like(weight)[:, None]], axis=1)
        qxx = jnp.concatenate([qxx, (weight**2 * qmm[:, j])[:, None]], axis=1)
        qxm = jnp.concatenate([qxm, (weight * qmm[:, j])[:, None]], axis=1)
        start_var = jnp.concatenate([start_var, jnp.zeros(1)])
        scale = jnp.concatenate([scale, jnp.full((1,), diffusion)])
        link, q_link = weight, weight * qxm[:, j]
    start = jnp.diag(start_var)
    block, q_block = None, None
    if rate_error is not None:
        phi, qxx, c, qxm, start = _with_process(phi, qxx, c, qxm, start, rate_error)
        block, q_block = rate_error.transition, rate_error.state_noise
        scale = jnp.concatenate([scale, jnp.ones(block.shape[-1])])  # its own noise
        r = r + rate_error.mean_noise
    transition = (phi, link, block)
    # the new state noise as its parts: a diagonal, the running mean's entry (both per unit
    # level), the rate error's block (which no level changes)
    q = (qxx, q_link, q_block)
    if not centred:
        return _anchored(observed, transition, c, q, qxm, r, update, start, scale,
                         early)
    return _centred(observed, transition, c, q, qxm, r, update, start, j, scale,
                    early)


def _with_process(phi, qxx, c, qxm, start, process: RateErrorProcess):
    """The block filter's system with the rate error's states appended (their transition
    and state noise, square blocks, are applied apart: :func:`_transit`,
    :func:`_plus_noise`)."""
    n, s = c.shape
    k = s + process.stationary.shape[0]
    start = jnp.zeros((k, k)).at[:s, :s].set(start).at[s:, s:].set(process.stationary)
    return (jnp.concatenate([phi, jnp.zeros((n, k - s))], axis=1),
            jnp.concatenate([qxx, jnp.zeros((n, k - s))], axis=1),
            jnp.concatenate([c, process.to_mean], axis=1),
            jnp.concatenate([qxm, process.cross_noise], axis=1), start)


def _transit(transition, m, j):
    """The transition applied to ``m`` along its leading (state) axis: a diagonal, the
    running mean's link (state ``j + 1`` gains ``link`` times state ``j``) and the rate
    error's block on the last states; O(states) where a dense product is O(states^2) per
    column (the filter's ``F P F'`` was its cost)."""
    diag, link, block = transition
    out = diag.reshape((-1,) + (1,) * (m.ndim - 1)) * m
    if link is not None:
        out = out.at[j + 1].add(link * m[j])
    if block is not None:
        k = block.shape[-1]
        out = out.at[-k:].set(jnp.tensordot(block, m[-k:], axes=1))
    return out


def _plus_noise(cov, noise, scale, j):
    """``cov`` plus a block's new state noise given as its parts (:func:`ieee_innovations`):
    the diagonal and the running mean's covariance with the walk (states ``j + 1`` and
    ``j``), per unit level, times each state's ``scale``; the rate error's block."""
    diag, link, block = noise
    out = cov + jnp.diag(scale * diag)
    if link is not None:
        out = out.at[j + 1, j].add(scale[j] * link).at[j, j + 1].add(scale[j] * link)
    if block is not None:
        k = block.shape[-1]
        out = out.at[-k:, -k:].add(block)
    return out


def _centred(observed, transition, c, q, qxm, r, update, start_cov, j, scale, early):
    """The block filter with the walk (state ``j``) diffuse at the start and its running
    mean (state ``j + 1``) observed as zero at the end (module docstring)."""
    a = j + 1
    n_states = c.shape[1]
    start_d = jnp.zeros(n_states).at[j].set(1.0)  # the diffuse level's coefficients

    def step(scale, carry, row):
        mean, cov, d, pending = carry  # states at the previous block's end; d: of the level
        y, f_k, c_k, q_k, qxm_k, r_k, u_k = row
        pc = cov @ c_k
        s_mm = c_k @ pc + r_k
        s_xm = _transit(f_k, pc, j) + scale * qxm_k
        s_xx = _plus_noise(_transit(f_k, _transit(f_k, cov, j).T, j), q_k, scale, j)
        innovation = y - jnp.tensordot(c_k, mean, axes=1)
        predicted = _transit(f_k, mean, j)
        d_next = _transit(f_k, d, j)  # the level's coefficients in the predicted states
        # the first row learnt from reveals the diffuse level (the exact initial filter:
        # its own likelihood term is the constraint's, set after the scan)
        reveal = pending * u_k
        ordinary = (1.0 - pending) * u_k
        gain = ordinary * s_xm / s_mm + reveal * d_next
        mean = predicted + jnp.tensordot(gain, innovation, axes=0)
        cov = jax.lax.cond(
            reveal > 0,
            lambda: (s_xx + s_mm * jnp.outer(d_next, d_next) - jnp.outer(d_next, s_xm)
                     - jnp.outer(s_xm, d_next)),
            lambda: s_xx - ordinary * jnp.outer(s_xm, s_xm) / s_mm)
        d = (1.0 - reveal) * d_next
        return (mean, cov, d, pending * (1.0 - u_k)), (innovation, s_mm)

    start = (jnp.zeros((n_states, *observed.shape[1:])), start_cov, start_d, jnp.ones(()))
    (mean, cov, _, _), (innovation, total) = _scan(
        step, scale, start, (observed, transition, c, q, qxm, r, update), early)
    # the walk's weighted mean over the log, observed as zero
    first = jnp.argmax(update > 0)
    innovation = innovation.at[first].set(-mean[a])
    total = total.at[first].set(cov[a, a])
    return innovation, total


def _anchored(observed, transition, c, q, qxm, r, update, start_cov, scale, early):
    """The block filter with the walk from zero at the first block (``centred=False``)."""
    n_states = c.shape[1]

    def step(scale, carry, row):
        mean, cov = carry  # of the states at the previous block's end
        y, f_k, c_k, q_k, qxm_k, r_k, u_k = row
        pc = cov @ c_k
        s_mm = c_k @ pc + r_k
        s_xm = _transit(f_k, pc, -1) + scale * qxm_k
        s_xx = _plus_noise(_transit(f_k, _transit(f_k, cov, -1).T, -1), q_k, scale, -1)
        innovation = y - jnp.tensordot(c_k, mean, axes=1)
        gain = u_k * s_xm / s_mm
        mean = _transit(f_k, mean, -1) + jnp.tensordot(gain, innovation, axes=0)
        cov = s_xx - u_k * jnp.outer(s_xm, s_xm) / s_mm
        return (mean, cov), (innovation, s_mm)

    start = (jnp.zeros((n_states, *observed.shape[1:])), start_cov)
    _, (innovation, total) = _scan(step, scale, start,
                                   (observed, transition, c, q, qxm, r, update), early)
    return innovation, total


def _scan(step, scale, start, rows, early):
    """The filter's ``step(scale, carry, row)`` over ``rows`` (the observed, the transition,
    the observation's loadings, the new noise, its covariance with the mean, the white
    variance, the updates) from ``start`` (the states' means, states by columns, their
    covariance, then what else the filter carries): with ``early``, its constant states set
    before the rate error's (the last ``k``) over its rows and left out after
    (:func:`block_innovations`)."""
    n = rows[0].shape[0]
    rows_early, states = (0, 0) if early is None else early.shape
    at = _early_at(rows)
    carry = start
    if rows_early:
        carry = _with_early(carry, states, at)
    outputs = []
    for low, high in pairwise(sorted({0, n, rows_early})):
        if rows_early and low == rows_early:
            carry = _without_early(carry, states, at)
        part = jax.tree_util.tree_map(lambda x, low=low, high=high: x[low:high], rows)
        scale_part = scale
        if low < rows_early:
            part, scale_part = _early_rows(part, scale, early, at)
        carry, (innovation, total) = jax.lax.scan(
            lambda c, x, s=scale_part: step(s, c, x), carry, part)
        outputs.append((innovation, total))
    return carry, tuple(jnp.concatenate(o) for o in zip(*outputs, strict=True))


def _early_at(rows) -> int:
    """Where the early states go among the states: before the rate error's block."""
    (phi, _, block) = rows[1]
    return phi.shape[1] - (0 if block is None else block.shape[-1])


def _insert(x, values, at: int, axis: int):
    """``values`` inserted into ``x`` before index ``at`` along ``axis``."""
    head = jax.lax.slice_in_dim(x, 0, at, axis=axis)
    tail = jax.lax.slice_in_dim(x, at, x.shape[axis], axis=axis)
    return jnp.concatenate([head, values, tail], axis=axis)


def _with_early(carry, k: int, at: int):
    """The filter's carry with ``k`` constant states inserted at ``at``: means zero,
    variances one, independent of the rest (and, centred, no share of the diffuse
    level)."""
    mean, cov, *rest = carry
    mean = _insert(mean, jnp.zeros((k, *mean.shape[1:])), at, 0)
    cov = _insert(_insert(cov, jnp.zeros((k, cov.shape[1])), at, 0),
                  jnp.zeros((cov.shape[0] + k, k)), at, 1)
    cov = cov.at[at:at + k, at:at + k].set(jnp.eye(k))
    if rest and rest[0].ndim == 1:  # the diffuse level's coefficients
        rest = [_insert(rest[0], jnp.zeros(k), at, 0), *rest[1:]]
    return (mean, cov, *rest)


def _without_early(carry, k: int, at: int):
    """The carry with the ``k`` states at ``at`` left out (their marginal)."""
    keep = np.r_[0:at, at + k:carry[1].shape[0]]
    mean, cov, *rest = carry
    if rest and rest[0].ndim == 1:
        rest = [rest[0][keep], *rest[1:]]
    return (mean[keep], cov[np.ix_(keep, keep)], *rest)


def _early_rows(part, scale, early, at: int):
    """The early rows' system with the constant states inserted at ``at``: transition one,
    no new noise, read through ``early``."""
    observed, (phi, link, block), c, (qxx, q_link, q_block), qxm, r, update = part
    m, k = early.shape
    ones, zeros = jnp.ones((m, k)), jnp.zeros((m, k))
    return ((observed, (_insert(phi, ones, at, 1), link, block), _insert(c, early, at, 1),
             (_insert(qxx, zeros, at, 1), q_link, q_block), _insert(qxm, zeros, at, 1), r,
             update), _insert(scale, jnp.zeros(k), at, 0))
