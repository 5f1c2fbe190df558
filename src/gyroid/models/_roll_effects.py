"""The registry of roll-loop effects (paper B; docs/formats.md section 2), in the bench registry's
form: each effect declares its parameters (name, unit, default prior) with the same
:class:`~gyroid.models.Parameter` as the drift effects, and whether the discrepancy
workflow may add it.

Paper B's ideal loop has ``sf_error`` (the SINS roll gyro's scale-factor error ``D1``) and
``gs_bias`` (the stabiliser MEMS bias ``D0gs``); the candidates are ``roll_bias``,
``gs_rate_leak``, ``encoder_error`` and ``sf_nonlinearity``. The physics they enter lives in
one place, :mod:`gyroid.models._roll` (simulation and fitting both call it).
"""

from __future__ import annotations

from dataclasses import dataclass

from gyroid.models._effects import Parameter
from gyroid.models._priors import LogNormal, Normal
from gyroid.models._terms import expand_terms


@dataclass(frozen=True)
class RollEffect:
    """A named effect in paper B's loop (see :func:`gyroid.models._roll.stabiliser_angle_deg`)."""

    name: str
    formula: str
    what: str
    parameters: tuple[Parameter, ...]
    candidate: bool  # the discrepancy workflow may add it (not in paper B's ideal loop)
    columns: tuple[str, ...] = ()  # log columns it needs beyond the contract's minimum

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)


ROLL_EFFECTS: dict[str, RollEffect] = {
    e.name: e
    for e in (
        RollEffect("sf_error", "w_x = (1 + D1) w", "the SINS roll gyro's SF error D1",
                   (Parameter("D1", "1", "SINS roll-gyro scale-factor error", Normal(0.0, 2e-3),
                              hint="D1 needs a flight whose roll angle advances further (a "
                                   "longer or faster roll)"),),
                   candidate=False),
        RollEffect("gs_bias", "platform error D0gs t", "the stabiliser's MEMS bias D0gs",
                   (Parameter("D0gs", "deg/s", "stabiliser MEMS bias", Normal(0.0, 0.02),
                              hint="D0gs is told apart from D0 only by the stabiliser's MEMS "
                                   "output (gs_rate_deg_s) logged while the stabiliser "
                                   "holds the platform"),),
                   candidate=False),
        RollEffect("roll_bias", "w_x = D0 + (1 + D1) w", "an additive SINS roll-gyro bias D0",
                   (Parameter("D0", "deg/s", "SINS roll-gyro bias", Normal(0.0, 0.1),
                              hint="D0 needs the stabiliser's MEMS output (gs_rate_deg_s) "
                                   "from an ideal stabiliser"),),
                   candidate=True),
        RollEffect("gs_rate_leak", "platform error int (D1gs m + D0gs) / (1 + D1gs) dt",
                   "an overloaded stabiliser integrating its uncompensated rate with SF error "
                   "D1gs (needs gs_rate_deg_s)",
                   (Parameter("D1gs", "1", "stabiliser MEMS scale-factor error",
                              Normal(0.0, 1e-3),
                              hint="D1gs needs a stabiliser that is overloaded for part of the "
                                   "flight"),),
                   candidate=True, columns=("gs_rate_deg_s",)),
        RollEffect("encoder_error", "a sin(psi) + b cos(psi)",
                   "an encoder error periodic per revolution, a sin(psi) + b cos(psi)",
                   (Parameter("enc_a", "deg", "encoder error, sine part", Normal(0.0, 1.0),
                              hint="the encoder error needs whole turns of roll"),
                    Parameter("enc_b", "deg", "encoder error, cosine part", Normal(0.0, 1.0),
                              hint="the encoder error needs whole turns of roll")),
                   candidate=True),
        RollEffect("sf_nonlinearity", "w_x = D0 + (1 + D1 + D2 |w| / 1000) w",
                   "SF error growing with |w|: D2 per 1000 deg/s",
                   (Parameter("D2", "per 1000 deg/s", "SF error growth with |roll rate|",
                              Normal(0.0, 1e-3)),),
                   candidate=True),
    )
}

ROLL_PRESETS: dict[str, tuple[str, ...]] = {
    "ideal": ("sf_error", "gs_bias"),
    "loop": ("sf_error", "gs_bias", "roll_bias", "gs_rate_leak", "encoder_error"),
}

#: Parameters of every roll model that are not an effect's: the stabiliser angle's offset
#: and the three noise levels (``sigma_m_deg_s`` only for an ideal stabiliser, whose MEMS
#: output also observes ``D0gs``).
ROLL_NUISANCE: dict[str, Parameter] = {
    p.name: p
    for p in (
        Parameter("psi0", "deg", "stabiliser angle at the first sample", Normal(0.0, 10.0)),
        Parameter("sigma_gs_deg", "deg", "encoder read-out noise, sd", LogNormal(0.01, 2.0),
                  positive=True),
        Parameter("sigma_sins_deg_s", "deg/s", "SINS roll-gyro white noise per sample, sd",
                  LogNormal(0.02, 2.0), positive=True),
        Parameter("sigma_m_deg_s", "deg/s", "stabiliser MEMS white noise per sample, sd",
                  LogNormal(0.01, 3.0), positive=True),
    )
}


#: What separates each pair of loop parameters that a flight can leave confounded.
ROLL_CONFOUNDED: dict[tuple[str, str], str] = {
    ("D0", "D0gs"): "log the stabiliser's MEMS output (gs_rate_deg_s) while it holds the "
                    "platform (ideal stabiliser): it measures D0gs alone",
    ("D1", "D1gs"): "vary the roll rate while the stabiliser stays unsaturated, or hold it "
                    "ideal for part of the flight: D1 then acts alone",
    ("D0", "D1"): "vary the roll rate (a ramp or a reversal): D1 scales with it, D0 does not",
}


def roll_parameter(name: str) -> Parameter:
    """A roll-side parameter (an effect's, or ``psi0`` and the noise levels)."""
    for effect in ROLL_EFFECTS.values():
        for p in effect.parameters:
            if p.name == name:
                return p
    return ROLL_NUISANCE[name]


def resolve_roll_terms(spec: str | tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Expand roll presets and effect names, registry order; paper B's ideal loop is always
    in (every model of a roll log has ``sf_error`` and ``gs_bias``).

    >>> resolve_roll_terms("encoder_error")
    ('sf_error', 'gs_bias', 'encoder_error')
    """
    chosen = expand_terms(spec, ROLL_PRESETS, ROLL_EFFECTS, what="roll term")
    chosen.update(ROLL_PRESETS["ideal"])
    return tuple(name for name in ROLL_EFFECTS if name in chosen)
