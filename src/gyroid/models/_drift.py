"""The FOG drift model: the sum of the selected named effects (paper A, eqs. 1-3)."""

from __future__ import annotations

from collections.abc import Iterator

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from gyroid.errors import GyroidInputError
from gyroid.models import _effects as registry
from gyroid.models._design import row_blocks, rows_of, with_rows
from gyroid.models._effects import Effect, Parameter, Params
from gyroid.models._inputs import ACCEL_COLUMNS, FIELD_COLUMNS, H0_UT, DriftInputs
from gyroid.models._terms import resolve_terms


class DriftModel(eqx.Module):
    """Drift rate, deg/h, as the sum of named effects.

    >>> model = DriftModel.from_terms("thermal")
    >>> model.parameter_names
    ('w0', 'w1', 'w2', 'wD')
    """

    terms: tuple[str, ...] = eqx.field(static=True)

    @classmethod
    def from_terms(cls, spec: str | tuple[str, ...] | list[str]) -> DriftModel:
        return cls(terms=resolve_terms(spec))

    @property
    def effects(self) -> tuple[Effect, ...]:
        return tuple(registry.effect(name) for name in self.terms)

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        return tuple(p for e in self.effects for p in e.parameters)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def columns(self) -> tuple[str, ...]:
        """Log columns the selected effects need (besides time and drift)."""
        needed = {c for e in self.effects for c in e.columns}
        known = ("temperature_C", *FIELD_COLUMNS, *ACCEL_COLUMNS)
        return (*(c for c in known if c in needed), *sorted(needed - set(known)))

    @property
    def is_linear(self) -> bool:
        """True when the drift is linear in every parameter (a linear-Gaussian problem)."""
        return all(e.linear for e in self.effects)

    def __call__(self, params: Params, inputs: DriftInputs) -> Float[Array, " n"]:
        """Modelled drift, deg/h, for parameters given by name."""
        total = jnp.zeros(inputs.time_h.shape[0])
        for effect in self.effects:
            total = total + effect.contribution(params, inputs)
        return total

    def unpack(self, theta: Float[Array, " p"]) -> dict[str, Float[Array, ""]]:
        """Parameter vector (model order) to a name -> value mapping."""
        return {name: theta[i] for i, name in enumerate(self.parameter_names)}

    def predict(self, theta: Float[Array, " p"], inputs: DriftInputs) -> Float[Array, " n"]:
        """Modelled drift, deg/h, for a parameter vector in model order."""
        return self(self.unpack(theta), inputs)

    def input_ranges(self, inputs: DriftInputs) -> dict[str, list[float]]:
        """The range of every input the model reads (the temperature's level, its rate,
        field and specific-force components; only those the terms read) and of the elapsed time, as
        ``inputs`` has them: [min, max] by name."""
        out = {}
        reads_level = any("temperature_C" in e.columns for e in self.effects
                          if e.name != "temperature_rate")
        for name, values, read in (("temperature_C", inputs.temperature_C, reads_level),
                                   ("dT_dt_C_h", inputs.rate_C_h,
                                    "temperature_rate" in self.terms)):
            if read:
                values = np.asarray(values)
                out[name] = [float(values.min()), float(values.max())]
        for k, name in enumerate(FIELD_COLUMNS):
            if name in self.columns and inputs.field_rel is not None:
                h = np.asarray(inputs.field_rel[:, k]) * H0_UT
                out[name] = [float(h.min()), float(h.max())]
        for k, name in enumerate(ACCEL_COLUMNS):
            if name in self.columns and inputs.accel_g is not None:
                a = np.asarray(inputs.accel_g[:, k])
                out[name] = [float(a.min()), float(a.max())]
        time_h = np.asarray(inputs.time_h)
        out["elapsed_h"] = [float(time_h.min()), float(time_h.max())]
        return out

    def design(self, inputs: DriftInputs) -> Float[Array, "n p"]:
        """Design matrix of a linear model: ``predict(theta) == design @ theta``."""
        if not self.is_linear:
            nonlinear = [e.name for e in self.effects if not e.linear]
            raise ValueError(f"the model is not linear: {', '.join(nonlinear)}")
        return jnp.concatenate([e.design_columns(inputs) for e in self.effects], axis=1)

    def columns_at(self, inputs: DriftInputs, u_positive: Float[Array, " q"]
                   ) -> tuple[Float[Array, " n"], Float[Array, "n r"]]:
        """At positive parameters ``u_positive`` (logs, in parameter order): the prediction
        at zero real coefficients and its derivatives in them, exact since every effect is
        linear in its real coefficients (a linear model: zeros and its design)."""
        positive = np.array([p.positive for p in self.parameters], dtype=bool)
        real = np.flatnonzero(~positive)

        def predict(values):
            theta = (jnp.zeros(positive.size).at[real].set(values)
                     .at[np.flatnonzero(positive)].set(jnp.exp(u_positive)))
            return self.predict(theta, inputs)

        zero = jnp.zeros(real.size)
        return predict(zero), jax.jacfwd(predict)(zero)

    def design_blocks(self, inputs: DriftInputs, effects: tuple[Effect, ...] | list[Effect]
                      | None = None, rows: int | None = None
                      ) -> Iterator[tuple[slice, np.ndarray]]:
        """The design matrix of the linear ``effects`` (default: all, which must be linear)
        as NumPy blocks of at most ``rows`` rows (default
        :data:`gyroid.models._design.BLOCK_ROWS`), with the rows each covers."""
        effects = self.effects if effects is None else tuple(effects)
        for sl in row_blocks(inputs.n, rows):
            part = rows_of(inputs, sl)
            yield sl, np.concatenate([np.asarray(e.design_columns(part)) for e in effects],
                                     axis=1)

    def check_identifiable(self, inputs: DriftInputs, available: set[str] | frozenset[str]) -> None:
        """Refuse a log that cannot identify every coefficient, naming the column at fault."""
        for effect in self.effects:
            missing = [c for c in effect.columns if c not in available]
            if missing:
                raise GyroidInputError(
                    f"term {effect.name!r} needs column {missing[0]}, which the log lacks; "
                    f"add the column or drop the term from --terms"
                )
        linear = [e for e in self.effects if e.linear]
        names = [p.name for e in linear for p in e.parameters]
        owner = {p.name: e.name for e in linear for p in e.parameters}
        regressor = {p.name: p.regressor or "time_s" for e in linear for p in e.parameters}
        if not linear:
            return
        # The singular values and right vectors of the n x p matrix are those of its R
        # factor (p x p), accumulated block by block: no n x p copy is formed.
        r, first = None, None
        low, high = np.full(len(names), np.inf), np.full(len(names), -np.inf)
        for _, block in self.design_blocks(inputs, linear):
            r = with_rows(r, block)
            low, high = np.minimum(low, block.min(axis=0)), np.maximum(high, block.max(axis=0))
            first = block[0] if first is None else first
        if r is None or first is None:  # no rows
            return
        for j, name in enumerate(names):
            if name == "w0":
                continue
            if high[j] - low[j] <= 1e-9 * max(1.0, abs(low[j]), abs(high[j])):
                column = regressor[name]
                raise GyroidInputError(
                    f"column {column} does not vary enough to identify {name} of term "
                    f"{owner[name]!r} (its regressor is constant at {first[j]:.6g}); drop the "
                    f"term from --terms or use a log in which {column} varies"
                )
        scale = np.linalg.norm(r, axis=0)  # the columns' norms: R's columns have them
        scale[scale == 0] = 1.0
        singular, vectors = np.linalg.svd(r / scale)[1:]
        if singular.size < len(names) or singular[-1] < 1e-8 * singular[0]:
            weights = np.abs(vectors[-1])
            involved = [names[j] for j in np.argsort(-weights) if weights[j] > 0.1]
            terms = sorted({owner[n] for n in involved})
            raise GyroidInputError(
                f"the coefficients {', '.join(involved)} cannot be told apart on this log "
                f"(terms {', '.join(terms)} are collinear); drop one of those terms or use "
                "a log that varies them independently"
            )
        for effect in self.effects:
            if effect.name == "thermal_lag" and np.ptp(np.asarray(inputs.temperature_C)) == 0:
                raise GyroidInputError(
                    "column temperature_C is constant: term 'thermal_lag' cannot be "
                    "identified; drop it or use a log in which temperature_C varies"
                )
