"""The drift model's inputs: a log's columns plus the derived quantities, as a JAX pytree."""

from __future__ import annotations

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._change_signs import field_change_sign, temperature_change_sign
from gyroid.models._derived import (
    ACCEL_WINDOW_S,
    HYSTERESIS_DEADBAND_UT,
    RATE_WINDOW_S,
    centred_mean,
    temperature_rate_deg_c_per_h,
)

#: Lab temperature that relative temperature is measured from, degC (paper A).
T0_C = 21.0
#: Reference field strength, uT (paper A: close to the Earth's field).
H0_UT = 100.0
#: Log columns of the three field projections, in axis order OX, OY, OZ.
FIELD_COLUMNS = ("Hx_uT", "Hy_uT", "Hz_uT")
#: Log columns of the specific force along OX, OY, OZ, g (paper A eq. 1's overload).
ACCEL_COLUMNS = ("ax_g", "ay_g", "az_g")


class DriftInputs(eqx.Module):
    """Everything the drift effects read, one row per sample.

    Columns a log does not have are zeros here (the field: None); the model checks that
    every selected effect's columns exist before it is evaluated.
    """

    time_h: Float[Array, " n"]  # elapsed time since the first sample, h
    temperature_C: Float[Array, " n"]  # logged temperature, degC
    t_rel: Float[Array, " n"]  # temperature minus t0, degC
    rate_C_h: Float[Array, " n"]  # estimated dT/dt, degC/h
    #: Field projections over H0 (dimensionless), None for a log without field columns; the
    #: sign of each component's last change, None when no component changed by more than
    #: the dead band (zero throughout). None saves 0.24 GB of zeros each at 10^7 rows.
    field_rel: Float[Array, "n 3"] | None
    field_sign: Float[Array, "n 3"] | None
    t0_C: float = eqx.field(static=True, default=T0_C)
    #: A user's own logged quantities (--extra-columns), each minus its mean: (n, m).
    extra: Float[Array, "n m"] | None = None
    extra_names: tuple[str, ...] = eqx.field(static=True, default=())
    #: Specific force along OX, OY, OZ, g (the accelerometer averaged over
    #: ``ACCEL_WINDOW_S``), None for a log without accelerometer columns.
    accel_g: Float[Array, "n 3"] | None = None
    #: Sign of the last temperature change (+1 warming, -1 cooling, 0 before any), None
    #: for a log without a thermometer.
    temperature_sign: Float[Array, " n"] | None = None

    @property
    def n(self) -> int:
        return int(self.time_h.shape[0])


def inputs_from_arrays(
    time_s: np.ndarray,
    temperature_C: np.ndarray,
    rate_C_h: np.ndarray,
    field_uT: np.ndarray | None = None,
    field_sign: np.ndarray | None = None,
    *,
    t0_C: float = T0_C,
    origin_s: float | None = None,
    extra: Mapping[str, np.ndarray] | None = None,
    accel_g: np.ndarray | None = None,
    temperature_sign: np.ndarray | None = None,
) -> DriftInputs:
    """DriftInputs from given quantities (the simulators' truth, a flight's environment):
    elapsed time from ``origin_s`` (default: the first sample), field (n, 3) in uT (None:
    a log without field columns), specific force (n, 3) in g as the effects read it."""
    time_s = np.asarray(time_s, dtype=float)
    origin = time_s[0] if origin_s is None else origin_s
    temperature_C = np.asarray(temperature_C, dtype=float)
    # Each column goes to JAX as it is made, so that a long log's inputs are not held
    # twice.
    return DriftInputs(
        time_h=jnp.asarray((time_s - origin) / 3600.0),
        temperature_C=jnp.asarray(temperature_C),
        t_rel=jnp.asarray(temperature_C - t0_C),
        rate_C_h=jnp.asarray(rate_C_h),
        field_rel=None if field_uT is None else jnp.asarray(np.asarray(field_uT) / H0_UT),
        field_sign=None if field_sign is None or not np.any(field_sign)
        else jnp.asarray(field_sign),
        t0_C=float(t0_C),
        extra=None if not extra else jnp.asarray(np.column_stack(
            [np.asarray(v, dtype=float) - np.mean(v) for v in extra.values()])),
        extra_names=tuple(extra or ()),
        accel_g=None if accel_g is None else jnp.asarray(accel_g, dtype=float),
        temperature_sign=None if temperature_sign is None else jnp.asarray(
            temperature_sign, dtype=float),
    )


def build_inputs(
    columns: Mapping[str, np.ndarray],
    *,
    t0_C: float = T0_C,
    rate_window_s: float = RATE_WINDOW_S,
    deadband_uT: float = HYSTERESIS_DEADBAND_UT,
    extra_columns: tuple[str, ...] = (),
) -> DriftInputs:
    """Build :class:`DriftInputs` from log columns (``time_s`` required, the rest optional;
    ``extra_columns`` name the user's own columns that ``extra:COLUMN`` effects read)."""
    time_s = np.asarray(columns["time_s"], dtype=float)
    n = time_s.size
    if "temperature_C" in columns:
        temperature = np.asarray(columns["temperature_C"], dtype=float)
        rate = temperature_rate_deg_c_per_h(time_s, temperature, rate_window_s)
        temperature_sign = temperature_change_sign(temperature)
    else:
        temperature = np.full(n, t0_C)
        rate = np.zeros(n)
        temperature_sign = None
    field = sign = None
    if any(name in columns for name in FIELD_COLUMNS):
        field, sign = np.zeros((n, 3)), np.zeros((n, 3))
        for k, name in enumerate(FIELD_COLUMNS):
            if name in columns:
                field[:, k] = np.asarray(columns[name], dtype=float)
                sign[:, k] = field_change_sign(field[:, k], deadband_uT)
    accel = None
    if any(name in columns for name in ACCEL_COLUMNS):
        accel = np.zeros((n, 3))
        for k, name in enumerate(ACCEL_COLUMNS):
            if name in columns:
                accel[:, k] = centred_mean(time_s, columns[name], ACCEL_WINDOW_S)
    return inputs_from_arrays(time_s, temperature, rate, field, sign, t0_C=t0_C,
                              extra={name: columns[name] for name in extra_columns},
                              accel_g=accel, temperature_sign=temperature_sign)
