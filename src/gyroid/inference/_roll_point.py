"""The mode of paper B's loop on a roll log: linearised least squares for a start, then
BFGS (:class:`~gyroid.inference._mode.JointBFGS`) on the log-posterior, the covariance from
the inverse Hessian."""


from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from gyroid.inference._mode import JointBFGS, safe_inverse
from gyroid.inference._problem import AbstractProblem, PointEstimate
from gyroid.models._paper_b import DEG
from gyroid.models._priors import LogNormal, natural_with_sd

#: BFGS in standardised coordinates (v = v0 + scale z) over all of ``ALL_PARAMETERS``, so
#: that every model of a log shares one compilation: the entries outside the model have no
#: gradient, so BFGS never moves them. Standardised because D1 is known to 1e-7 while the
#: offsets are known to 1e-3: unscaled step tolerances would stop far too early.
_FINDER = JointBFGS(rtol=1e-10, atol=1e-10, max_steps=5000)


def _start(problem: AbstractProblem) -> dict[str, float]:
    """Starting values: the loop's offsets, D1 and the encoder terms from a linearised least
    squares of the stabiliser angle on the integrated SINS rate; the noise levels at their
    priors' medians; everything else zero."""
    t = np.asarray(problem.time_s)
    psi_x = np.cumsum(np.asarray(problem.sins)) * problem.sample_s
    y = np.asarray(problem.gs_angle) - psi_x
    design = np.column_stack([np.ones_like(t), -psi_x, t, np.sin(psi_x * DEG),
                              np.cos(psi_x * DEG)])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    start = {name: (prior.median if isinstance(prior, LogNormal) else 0.0)
             for name, prior in zip(problem.names, problem.priors, strict=True)}
    start |= dict(psi0=coef[0], D1=coef[1], D0gs=coef[2], enc_a=coef[3], enc_b=coef[4])
    if problem.ideal_gs:
        start["D0gs"] = float(np.median(np.asarray(problem.gs_rate)))
        start["D0"] = start["D0gs"] - coef[2]
    return start


def roll_point_estimate(problem: AbstractProblem) -> PointEstimate:
    """Linearised least squares for a start, then BFGS (optimistix) on the log-posterior;
    covariance from the inverse Hessian."""
    start = _start(problem)
    x0 = np.array([start[n] for n in problem.names])
    slot = np.asarray(problem.density.slot)
    v0 = np.asarray(problem.density.spread(problem.to_sampling(jnp.asarray(x0))))
    # Scales from the curvature at the start (diagonal of the Hessian), floored for safety;
    # 1 for the parameters outside the model (they have no curvature).
    curvature = np.abs(np.diag(_FINDER.curvature(problem.density.full, v0)))
    scale = 1.0 / np.sqrt(np.where(np.isfinite(curvature) & (curvature > 0), curvature, 1.0))
    found = _FINDER.minimise(problem.density.full, v0, scale)
    cov = safe_inverse(found.curvature[np.ix_(slot, slot)])
    u = found.value[slot]
    x, sd = natural_with_sd(u, cov, problem.positive)
    return PointEstimate(problem.names, u, cov, dict(zip(problem.names, x.tolist(), strict=True)),
                         dict(zip(problem.names, sd.tolist(), strict=True)), found.converged,
                         found.message)
