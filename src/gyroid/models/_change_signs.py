"""Signs of a quantity's last change, by a Schmitt trigger (a dead band against noise): of
each field component (``magnetic_hysteresis``) and of the temperature
(``thermal_hysteresis``)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from gyroid.models._derived import HYSTERESIS_DEADBAND_UT, SIGN_POINTS, TEMPERATURE_DEADBAND_C


def field_change_sign(
    field_uT: Float[np.ndarray, " n"], deadband_uT: float = HYSTERESIS_DEADBAND_UT
) -> Float[np.ndarray, " n"]:
    """Sign of the last change of a field component: +1 rising, -1 falling, 0 before any.

    A Schmitt-trigger detector: the sign flips only when the field has moved more than
    ``deadband_uT`` away from its last extreme, so magnetometer noise does not flip it. A
    field that never spans the dead band has no change (zeros at once); otherwise the
    detector runs as a compiled scan (sequential by nature; 10^7 samples in well under a
    second).
    """
    field = np.asarray(field_uT, dtype=float)
    if field.size == 0 or np.ptp(field) <= deadband_uT:
        return np.zeros(field.size)
    return np.asarray(_schmitt(jnp.asarray(field), jnp.asarray(float(deadband_uT))))


def temperature_change_sign(temperature_C: np.ndarray,
                            deadband_C: float = TEMPERATURE_DEADBAND_C) -> np.ndarray:
    """Sign of the last temperature change (+1 warming, -1 cooling, 0 before any), by the
    same Schmitt trigger as :func:`field_change_sign`, run on at most ``SIGN_POINTS`` evenly
    spaced samples (a temperature's turn is slow against them) and held in between."""
    temperature = np.asarray(temperature_C, dtype=float)
    if temperature.size == 0 or np.ptp(temperature) <= deadband_C:
        return np.zeros(temperature.size)
    every = max(1, -(-temperature.size // SIGN_POINTS))
    state, low, high = 0.0, temperature[0], temperature[0]
    thinned = temperature[::every]
    signs = np.empty(thinned.size)
    for k, value in enumerate(thinned):
        if state >= 0.0:
            high = max(high, value)
        if state <= 0.0:
            low = min(low, value)
        if state <= 0.0 and value > low + deadband_C:
            state, high = 1.0, value
        elif state >= 0.0 and value < high - deadband_C:
            state, low = -1.0, value
        signs[k] = state
    return np.repeat(signs, every)[: temperature.size]


@jax.jit
def _schmitt(field, deadband):
    def step(carry, h):
        state, low, high = carry
        high = jnp.where(state >= 0.0, jnp.maximum(high, h), high)
        low = jnp.where(state <= 0.0, jnp.minimum(low, h), low)
        rise = (state <= 0.0) & (h > low + deadband)
        fall = ~rise & (state >= 0.0) & (h < high - deadband)
        state = jnp.where(rise, 1.0, jnp.where(fall, -1.0, state))
        high = jnp.where(rise, h, high)
        low = jnp.where(fall, h, low)
        return (state, low, high), state

    _, out = jax.lax.scan(step, (jnp.zeros(()), field[0], field[0]), field)
    return out
