"""The contributions of the drift effects that are not linear in their own parameters
(:mod:`gyroid.models._effects` names them): the thermal lag, a bias step, a start-up
transient; pure JAX functions of the parameters and the inputs, deg/h."""

from __future__ import annotations

from collections.abc import Mapping

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._derived import lagged_temperature
from gyroid.models._inputs import DriftInputs

Params = Mapping[str, Float[Array, ""]]


def thermal_lag(params: Params, x: DriftInputs) -> Float[Array, " n"]:
    tau_h = params["tau_lag_min"] / 60.0
    lagged = lagged_temperature(x.time_h, x.temperature_C, tau_h) - x.t0_C
    t = x.t_rel
    zero = jnp.zeros(())
    w1 = params.get("w1", zero)
    w2 = params.get("w2", zero)
    w3 = params.get("w3", zero)
    return w1 * (lagged - t) + w2 * (lagged**2 - t**2) + w3 * (lagged**3 - t**3)


#: A bias step's edge, as a fraction of the log's duration (a logistic, so that its time is
#: a smooth parameter), and the grid of step times tried, fractions of the duration.
STEP_EDGE_FRACTION = 1.0 / 200.0
STEP_GRID = np.linspace(0.01, 0.99, 99)


def bias_step(params: Params, x: DriftInputs) -> Float[Array, " n"]:
    elapsed = x.time_h - x.time_h[0]
    edge_h = jnp.maximum(elapsed[-1] * STEP_EDGE_FRACTION, 1e-6)
    return params["w_step"] * jax.nn.sigmoid((elapsed - params["t_step_h"]) / edge_h)


def step_times(x: DriftInputs) -> np.ndarray:
    elapsed = np.asarray(x.time_h) - float(np.asarray(x.time_h)[0])
    return STEP_GRID * max(float(elapsed[-1]), 1e-6)


def warmup(params: Params, x: DriftInputs) -> Float[Array, " n"]:
    tau_h = params["tau_warmup_min"] / 60.0
    return params["w_warmup"] * jnp.exp(-x.time_h / tau_h)
