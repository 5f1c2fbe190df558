"""The registry of named drift effects (docs/formats.md section 2).

Each :class:`Effect` declares its parameters (name, unit, default prior), the log columns it
needs and its contribution to the drift, deg/h, as a pure JAX function of the parameters
and the :class:`~gyroid.models._inputs.DriftInputs`. The drift model, the fits, the reports and the
discrepancy search all read this one registry.

Paper A's effects: ``bias``, ``temperature``, ``temperature_sq``, ``temperature_rate``,
``magnetic_x/y/z``, and eq. 1's overload ``overload_x/y/z`` (``n_k a_k``) and
``overload_sq_x/y/z`` (``n_kk a_k^2``), ``a`` the specific force in g. Candidate effects
(what the discrepancy workflow may find missing; it tries paper A's absent ones too):
``thermal_lag``, ``warmup``, ``time_trend``, ``magnetic_hysteresis``,
``temperature_cubic``, ``bias_step``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS, DriftInputs
from gyroid.models._nonlinear_effects import (  # noqa: F401  (STEP_GRID: the step's grid)
    STEP_EDGE_FRACTION,
    STEP_GRID,
    bias_step,
    step_times,
    thermal_lag,
    warmup,
)
from gyroid.models._priors import LogNormal, Normal, Prior

Params = Mapping[str, Float[Array, ""]]

#: Signatures of the effects that read nothing but the clock.
CLOCK_SIGNATURES = ("elapsed time", "start-up transient")


@dataclass(frozen=True)
class Parameter:
    """One coefficient of an effect."""

    name: str
    unit: str
    description: str
    prior: Prior  # paper A's FOG-sized prior (``--priors paper_a_fog``)
    positive: bool = False
    #: The regressor's physical span over which the default log-scaled prior lets this
    #: coefficient move the drift by ten times the log's drift scale (regressor units:
    #: degC for w1, degC^2 for w2, degC/h for wD, H/H0 for the field terms, h for w_trend).
    span: float = 1.0
    #: For a positive parameter whose plausible values depend on the log (a step's time):
    #: the starting values to try, from the log's inputs (else multiples of the median).
    start_values: Callable[[DriftInputs], np.ndarray] | None = None
    #: The log column whose variation identifies this coefficient (named in messages when
    #: it does not vary), e.g. temperature_C for w1, Hx_uT for wx, time_s for w_trend.
    regressor: str | None = None
    #: What a log needs for this parameter to be identified (the identifiability check's
    #: advice); by default, that its regressor varies more.
    hint: str | None = None


@dataclass(frozen=True)
class Effect:
    """A named additive effect in the gyro's drift, deg/h.

    ``design`` is given for effects linear in their own parameters: it returns the
    ``(n, k)`` matrix whose product with the parameters is the contribution. Other effects
    give ``contribution`` directly. ``reads`` names parameters of other effects that the
    contribution uses (``thermal_lag`` reads the temperature coefficients).
    """

    name: str
    formula: str
    parameters: tuple[Parameter, ...]
    columns: tuple[str, ...]
    paper: bool
    design: Callable[[DriftInputs], Float[Array, "n k"]] | None = None
    nonlinear: Callable[[Params, DriftInputs], Float[Array, " n"]] | None = None
    reads: tuple[str, ...] = field(default=())
    needs_effects: tuple[str, ...] = field(default=())
    #: What the residuals of a model lacking this effect line up with (a key of what
    #: :func:`gyroid.workflows._discrepancy.regressors` returns).
    signature: str = "elapsed time"

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def reads_only_clock(self) -> bool:
        """True for an effect of elapsed time alone (warmup, time_trend, bias_step): it says
        when, not why, and extrapolating it beyond the fitted span is extrapolation."""
        return self.signature in CLOCK_SIGNATURES

    @property
    def linear(self) -> bool:
        """True when the contribution is linear in this effect's own parameters."""
        return self.design is not None

    def design_columns(self, inputs: DriftInputs) -> Float[Array, "n k"]:
        """The effect's design columns (one per parameter) at ``inputs``: its contribution
        is their product with the coefficients. ValueError for a nonlinear effect."""
        if self.design is None:
            raise ValueError(f"{self.name} is not linear in its coefficients: it has no design")
        return self.design(inputs)

    def contribution(self, params: Params, inputs: DriftInputs) -> Float[Array, " n"]:
        """The effect's additive contribution to the drift, deg/h."""
        if self.design is not None:
            coefficients = jnp.stack([params[name] for name in self.parameter_names])
            return self.design(inputs) @ coefficients
        assert self.nonlinear is not None
        return self.nonlinear(params, inputs)


def _column(values: Callable[[DriftInputs], Float[Array, " n"]]):
    return lambda x: values(x)[:, None]


def _field_column(k: int):
    return lambda x: x.field_rel[:, k : k + 1]


def _accel_column(k: int, power: int):
    return lambda x: x.accel_g[:, k : k + 1] ** power


_MAGNETIC_UNIT = "deg/h per 100 uT"

EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect(
            name="bias",
            signature="constant",
            formula="w0",
            parameters=(Parameter("w0", "deg/h", "constant drift", Normal(0.0, 10.0)),),
            columns=(),
            paper=True,
            design=lambda x: jnp.ones((x.time_h.shape[0], 1)),
        ),
        Effect(
            name="temperature",
            signature="temperature",
            formula="w1 t, t = T - t0",
            parameters=(
                Parameter("w1", "deg/h/degC", "linear temperature sensitivity", Normal(0.0, 1.0),
                          span=10.0, regressor="temperature_C"),
            ),
            columns=("temperature_C",),
            paper=True,
            design=_column(lambda x: x.t_rel),
        ),
        Effect(
            name="temperature_sq",
            signature="temperature^2",
            formula="w2 t^2",
            parameters=(
                Parameter(
                    "w2", "deg/h/degC^2", "quadratic temperature sensitivity", Normal(0.0, 0.1),
                    span=100.0, regressor="temperature_C",
                ),
            ),
            columns=("temperature_C",),
            paper=True,
            design=_column(lambda x: x.t_rel**2),
        ),
        Effect(
            name="temperature_rate",
            signature="dT/dt",
            formula="wD dT/dt, dT/dt in degC/h",
            parameters=(
                Parameter(
                    "wD",
                    "(deg/h)/(degC/h)",
                    "sensitivity to the rate of temperature change",
                    Normal(0.0, 10.0),
                    span=10.0,
                    regressor="temperature_C",
                    hint="wD needs a log in which the temperature's rate (dT/dt) varies more",
                ),
            ),
            columns=("temperature_C",),
            paper=True,
            design=_column(lambda x: x.rate_C_h),
        ),
        *(
            Effect(
                name=f"magnetic_{axis}",
                signature=f"H{axis}",
                formula=f"w{axis} H{axis}/H0, H0 = 100 uT",
                parameters=(
                    Parameter(
                        f"w{axis}",
                        _MAGNETIC_UNIT,
                        f"sensitivity to the field along O{axis.upper()}",
                        Normal(0.0, 2.0),
                        regressor=FIELD_COLUMNS[k],
                    ),
                ),
                columns=(FIELD_COLUMNS[k],),
                paper=True,
                design=_field_column(k),
            )
            for k, axis in enumerate("xyz")
        ),
        *(
            Effect(
                name=f"overload{'_sq' * (power - 1)}_{axis}", signature=f"a{axis}{sq}",
                formula=(f"n{axis * power} a{axis}{sq}, a{axis} the specific force along "
                         f"O{axis.upper()} in g"),
                parameters=(Parameter(
                    f"n{axis * power}", f"deg/h per g{sq}",
                    f"{('linear', 'quadratic')[power - 1]} sensitivity to the overload along "
                    f"O{axis.upper()}", Normal(0.0, 1.0 / power), regressor=ACCEL_COLUMNS[k],
                    hint=(f"n{axis * power} needs orientations (or a centrifuge) that move "
                          f"the specific force along O{axis.upper()} independently")),),
                columns=(ACCEL_COLUMNS[k],), paper=True, design=_accel_column(k, power))
            for power, sq in ((1, ""), (2, "^2"))
            for k, axis in enumerate("xyz")
        ),
        Effect(
            name="thermal_lag",
            signature="dT/dt",
            formula=(
                "the temperature terms see T_lag, tau dT_lag/dt = T - T_lag: adds "
                "w1 (t_lag - t) + w2 (t_lag^2 - t^2) + w3 (t_lag^3 - t^3)"
            ),
            parameters=(
                Parameter(
                    "tau_lag_min",
                    "min",
                    "time constant of the lag between the logged and the effective temperature",
                    LogNormal(10.0, 1.5),
                    positive=True,
                ),
            ),
            columns=("temperature_C",),
            paper=False,
            nonlinear=thermal_lag,
            reads=("w1", "w2", "w3"),
            needs_effects=("temperature",),
        ),
        Effect(
            name="warmup",
            signature="start-up transient",
            formula="w_warmup exp(-(time - time[0]) / tau_warmup)",
            parameters=(
                Parameter(
                    "w_warmup", "deg/h", "start-up transient at the first sample", Normal(0.0, 10.0)
                ),
                Parameter(
                    "tau_warmup_min",
                    "min",
                    "decay time of the start-up transient",
                    LogNormal(20.0, 1.5),
                    positive=True,
                ),
            ),
            columns=(),
            paper=False,
            nonlinear=warmup,
        ),
        Effect(
            name="time_trend",
            signature="elapsed time",
            formula="w_trend (time - time[0]), time in h",
            parameters=(
                Parameter(
                    "w_trend", "deg/h per h", "drift growing with elapsed time", Normal(0.0, 1.0),
                    regressor="time_s", hint="w_trend needs a longer log",
                ),
            ),
            columns=(),
            paper=False,
            design=_column(lambda x: x.time_h),
        ),
        Effect(
            name="magnetic_hysteresis",
            signature="sign of the last field change",
            formula=(
                "hys_x s_x + hys_y s_y + hys_z s_z, s_k = sign of the last change of H_k "
                "(+1 rising, -1 falling, 0 before any; 10 uT dead band)"
            ),
            parameters=tuple(
                Parameter(
                    f"hys_{axis}",
                    "deg/h",
                    f"half-width of the hysteresis loop along O{axis.upper()}",
                    Normal(0.0, 1.0),
                    regressor=FIELD_COLUMNS[k],
                )
                for k, axis in enumerate("xyz")
            ),
            columns=FIELD_COLUMNS,
            paper=False,
            design=lambda x: jnp.zeros((x.n, 3)) if x.field_sign is None else x.field_sign,
        ),
        Effect(
            name="bias_step",
            signature="elapsed time",
            formula=("w_step from t_step_h on (h since the log's start; a logistic edge of "
                     "1/200 of the log's duration)"),
            parameters=(
                Parameter("w_step", "deg/h", "size of the bias step", Normal(0.0, 10.0)),
                Parameter("t_step_h", "h", "time of the step since the log's start",
                          LogNormal(5.0, 2.0), positive=True, start_values=step_times),
            ),
            columns=(),
            paper=False,
            nonlinear=bias_step,
        ),
        Effect(
            name="thermal_hysteresis",
            signature="sign of the last temperature change",
            formula=("w_hys s_T, s_T = sign of the last temperature change (+1 warming, -1 "
                     "cooling, 0 before any; 0.5 degC dead band)"),
            parameters=(Parameter(
                "w_hys", "deg/h", "half-width of the thermal hysteresis loop (warming "
                "against cooling at one temperature)", Normal(0.0, 1.0),
                regressor="temperature_C",
                hint="w_hys needs a log in which the temperature both rises and falls"),),
            columns=("temperature_C",), paper=False,
            design=lambda x: (jnp.zeros((x.n, 1)) if x.temperature_sign is None
                              else x.temperature_sign[:, None])),
        Effect(
            name="temperature_cubic",
            signature="temperature^3",
            formula="w3 t^3",
            parameters=(
                Parameter("w3", "deg/h/degC^3", "cubic temperature sensitivity", Normal(0.0, 0.01),
                          span=1000.0, regressor="temperature_C"),
            ),
            columns=("temperature_C",),
            paper=False,
            design=_column(lambda x: x.t_rel**3),
        ),
    )
}

#: Prefix of the effects made from a user's own columns (``--extra-columns``).
EXTRA_PREFIX = "extra:"


@functools.cache
def extra_effect(column: str) -> Effect:
    """``extra:COLUMN``: linear in the column's deviation from its mean."""
    def design(x: DriftInputs) -> Float[Array, "n 1"]:
        if x.extra is None:
            raise ValueError(f"the inputs hold no extra column {column!r}")
        k = x.extra_names.index(column)
        return x.extra[:, k : k + 1]

    return Effect(
        name=EXTRA_PREFIX + column, signature=column,
        formula=f"w_extra_{column} ({column} - mean)",
        parameters=(Parameter(f"w_extra_{column}", f"deg/h per unit of {column}",
                              f"sensitivity to the logged {column}", Normal(0.0, 10.0),
                              regressor=column),),
        columns=(column,), paper=False, design=design)


def effect(name: str) -> Effect:
    """A registry effect, or an ``extra:COLUMN`` effect."""
    if name.startswith(EXTRA_PREFIX):
        return extra_effect(name[len(EXTRA_PREFIX):])
    return EFFECTS[name]


def parameter(name: str) -> Parameter:
    """A registry parameter, or an extra effect's ``w_extra_COLUMN``."""
    if name in PARAMETERS:
        return PARAMETERS[name]
    if name.startswith("w_extra_"):
        return extra_effect(name[len("w_extra_"):]).parameters[0]
    raise KeyError(name)


#: Effects the discrepancy workflow may add (not in paper A's model).
CANDIDATES: tuple[str, ...] = tuple(name for name, e in EFFECTS.items() if not e.paper)

#: Every parameter in the registry, by name.
PARAMETERS: dict[str, Parameter] = {p.name: p for e in EFFECTS.values() for p in e.parameters}
