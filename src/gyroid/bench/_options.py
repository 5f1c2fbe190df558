"""How a bench log becomes its posterior problem: the options of a bench fit as one typed
object (:class:`BenchOptions`), each default written here once and checked when made.
``gyroid fit``, ``gyroid batch``, ``gyroid pool`` (each run's fit), :func:`fit_log`,
:func:`fit_pool` and :meth:`BenchProblem.from_log` all take it and pass it down whole."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from gyroid.errors import GyroidInputError
from gyroid.models._inputs import T0_C
from gyroid.models._prior_scales import PRIOR_SETS
from gyroid.models._priors import Prior
from gyroid.noise._model import NoiseModel, noise_choice, noise_model


@dataclass(frozen=True)
class BenchOptions:
    """The options of a bench fit. A wrong one is one message when the object is made, before
    any log is read.

    ``noise``: a noise model or its name (``auto``, the default: IEEE 952's white + flicker +
    rate random walk whatever the log, :data:`~gyroid.noise.DEFAULT_NOISE`; ``white``;
    ``white+gm``; ``white+flicker+rw``). ``priors`` overrides single parameters' priors by
    name over the ``prior_set`` (``default``, scaled to the log; ``paper_a_fog``; ``flat``).
    ``t0_C``: the reference temperature t0, degC (t = T - t0). ``rate_window_s``: the dT/dt
    estimator's window, s (None, the default: chosen from the data). ``segment_means``: a
    burst-sampled log fitted on one row per contiguous segment (its mean), unless the noise
    model carries the wander between bursts itself. ``errors_in_variables=False`` leaves the
    thermometer's noise in dT/dt out of the likelihood."""

    noise: str | NoiseModel = "auto"
    priors: Mapping[str, Prior] = field(default_factory=dict)
    prior_set: str = "default"
    t0_C: float = T0_C
    rate_window_s: float | None = None
    segment_means: bool = False
    errors_in_variables: bool = True

    def __post_init__(self) -> None:
        noise_model(self.noise)  # an unknown name: one message naming the models
        if self.prior_set not in PRIOR_SETS:
            raise GyroidInputError(f"prior set {self.prior_set!r} (--priors): use one of "
                                   f"{', '.join(PRIOR_SETS)} or a .toml file")
        if not math.isfinite(self.t0_C) or not -273.15 < self.t0_C < 1000.0:
            raise GyroidInputError(f"reference temperature {self.t0_C} (--t0): give t0 in "
                                   "degC, a finite number above -273.15")
        window = self.rate_window_s
        if window is not None and not (math.isfinite(window) and window > 0):
            raise GyroidInputError(f"dT/dt window {window} (--rate-window): give positive "
                                   "seconds, or None (auto) to choose it from the data")

    @property
    def noise_model(self) -> NoiseModel:
        """The noise model ``noise`` names."""
        return noise_model(self.noise)

    @property
    def noise_choice(self) -> str | None:
        """Why the fit has its noise model when gyroid chose it (``auto``), and that a burst
        log's samples are fitted where segment means were asked for under a model carrying
        the wander between bursts; None for a model asked for by name, and nothing more."""
        why = noise_choice(self.noise)
        if self.segment_means and not self.fits_segment_means:
            why = ((why or f"asked for: {self.noise_model.name}")
                   + " (on the samples: the noise model carries the wander between bursts)")
        return why

    @property
    def fits_segment_means(self) -> bool:
        """Whether a burst log is fitted on its segments' means: asked for, and the noise
        model does not carry the wander between bursts (then the samples are fitted)."""
        return self.segment_means and not self.noise_model.wanders
