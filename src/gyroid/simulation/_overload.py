"""A simulator of an overload bench (paper A eq. 1): the gyro dwells with the specific force
(1 g, gravity) along a chosen set of its axes' directions, turned between dwells, at the
lab's temperature with a slow wander (no magnetometer: the field turns with the unit). A
six-position tumble (+X, -X, +Y, -Y, +Z, -Z) pins the bias and the three linear
g-sensitivities; fewer orientations leave combinations undetermined
(:mod:`gyroid.models._orientations`), which is what a fit must then say.

As on the other benches the drift is evaluated on the true inputs (the true specific force,
a step at each turn) and the log holds the measured ones (accelerometer noise added).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

import numpy as np

from gyroid.errors import GyroidInputError
from gyroid.models._inputs import T0_C
from gyroid.simulation._bench import (
    OVERLOAD_SENSITIVITIES,
    PAPER_A_THERMAL,
    SimulatedBench,
    TrueInputs,
    lab_wander,
    simulate_bench,
)
from gyroid.simulation._noise import GyroNoise

#: The overload preset's default truth, deg/h and deg/h per g.
OVERLOAD_TRUTH = {"w0": PAPER_A_THERMAL["w0"], **OVERLOAD_SENSITIVITIES}

_DIRECTIONS = {f"{sign}{axis}": value * np.eye(3)[k] for k, axis in enumerate("XYZ")
               for sign, value in (("+", 1.0), ("-", -1.0))}


@dataclass(frozen=True)
class OverloadProtocol:
    """Dwells with the specific force along ``orientations`` (each +X, -X, +Y, -Y, +Z or
    -Z, in g: 1 g at rest), ``dwell_min`` each, at ``g_level`` g (1: gravity; more: a
    centrifuge's arm)."""

    orientations: tuple[str, ...] = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
    dwell_min: float = 30.0
    g_level: float = 1.0
    lab_C: float = T0_C
    temperature_wander_C: float = 0.2
    wander_period_h: float = 3.0
    sample_s: float = 1.0

    def __post_init__(self) -> None:
        unknown = [o for o in self.orientations if o not in _DIRECTIONS]
        if unknown or not self.orientations:
            raise GyroidInputError(
                f"orientations {', '.join(unknown) or '(none)'}: use a comma list of "
                f"{', '.join(_DIRECTIONS)}")

    @property
    def duration_s(self) -> float:
        return 60.0 * self.dwell_min * len(self.orientations)

    def stretched(self, hours: float | None = None, rate_hz: float | None = None
                  ) -> OverloadProtocol:
        """The same dwells lasting ``hours`` in all, sampled at ``rate_hz``."""
        dwell = self.dwell_min if hours is None else hours * 60.0 / len(self.orientations)
        return replace(self, dwell_min=dwell,
                       sample_s=self.sample_s if rate_hz is None else 1.0 / rate_hz)

    def true_inputs(self) -> TrueInputs:
        """The dwells' sample times and true inputs (the lab's wandering temperature)."""
        time_s, accel_g = self.schedule()
        temperature, rate = lab_wander(time_s, self.lab_C, self.temperature_wander_C,
                                       self.wander_period_h)
        return TrueInputs(time_s, temperature, rate, accel_g=accel_g)

    def schedule(self) -> tuple[np.ndarray, np.ndarray]:
        """Sample times, s, and the true specific force, g, shape (n, 3)."""
        time_s = np.arange(0.0, self.duration_s, self.sample_s)
        which = np.minimum((time_s // (60.0 * self.dwell_min)).astype(int),
                           len(self.orientations) - 1)
        vectors = np.array([_DIRECTIONS[o] for o in self.orientations]) * self.g_level
        return time_s, vectors[which]


def simulate_overload_bench(
    *,
    parameters: Mapping[str, float] | None = None,
    effects: Mapping[str, Mapping[str, float]] | None = None,
    protocol: OverloadProtocol | None = None,
    noise: GyroNoise | None = None,
    seed: int = 0,
    average_s: float | None = None,
    t0_C: float = T0_C,
    say: Callable[[str], None] | None = None,
) -> SimulatedBench:
    """Simulate the overload bench (default: the six-position tumble and
    :data:`OVERLOAD_TRUTH`; ``effects`` and ``say`` as for the thermal bench's)."""
    protocol = protocol or OverloadProtocol()
    return simulate_bench("overload", protocol,
                          OVERLOAD_TRUTH if parameters is None else parameters, effects=effects,
                          noise=noise, seed=seed, average_s=average_s, t0_C=t0_C, say=say,
                          detail=f", orientations {', '.join(protocol.orientations)}")
