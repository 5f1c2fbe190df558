"""``--terms``: presets and effect names to the effects of a drift model (docs/formats.md
section 2).

``thermal`` and ``magnetic`` are paper A's two models; ``full`` is both; ``overload`` is
the bias and eq. 1's three linear g-sensitivities. Any registry effect
(:mod:`gyroid.models._effects`) or a user's column as ``extra:COLUMN`` may be added by name.
The roll side's terms (:mod:`gyroid.models._roll_effects`) are expanded by the same
:func:`expand_terms`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from gyroid.errors import GyroidInputError
from gyroid.models._effects import EFFECTS, EXTRA_PREFIX, effect

PRESETS: dict[str, tuple[str, ...]] = {
    "thermal": ("bias", "temperature", "temperature_sq", "temperature_rate"),
    "magnetic": ("bias", "magnetic_x", "magnetic_y", "magnetic_z"),
    "overload": ("bias", "overload_x", "overload_y", "overload_z"),
}
PRESETS["full"] = PRESETS["thermal"] + PRESETS["magnetic"][1:]


def expand_terms(
    spec: str | tuple[str, ...] | list[str],
    presets: Mapping[str, tuple[str, ...]],
    names: Mapping[str, object],
    *,
    what: str = "term",
    also: Callable[[str], bool] = lambda _item: False,
) -> set[str]:
    """The effect names a comma list of presets and names stands for (bench and roll).

    ``also`` accepts further items (the bench's ``extra:COLUMN``); anything else is refused
    with the known names.
    """
    items = spec.split(",") if isinstance(spec, str) else list(spec)
    chosen: set[str] = set()
    for raw in items:
        item = raw.strip()
        if not item:
            continue
        if item in presets:
            chosen.update(presets[item])
        elif item in names or also(item):
            chosen.add(item)
        else:
            known = ", ".join([*presets, *names])
            raise GyroidInputError(
                f"unknown {what} {item!r} in --terms; use a preset or effect name: {known}"
            )
    return chosen


def resolve_terms(spec: str | tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """Expand a comma list of effect names and presets into effect names, registry order.

    >>> resolve_terms("magnetic,time_trend")
    ('bias', 'magnetic_x', 'magnetic_y', 'magnetic_z', 'time_trend')
    """
    chosen = expand_terms(spec, PRESETS, EFFECTS, also=lambda item: (
        item.startswith(EXTRA_PREFIX) and len(item) > len(EXTRA_PREFIX)))
    if not chosen:
        raise GyroidInputError("--terms is empty; give e.g. 'thermal', 'magnetic' or 'full'")
    for name in chosen:
        missing = [need for need in effect(name).needs_effects if need not in chosen]
        if missing:
            raise GyroidInputError(
                f"term {name!r} acts on the temperature terms; add {', '.join(missing)!s} "
                "to --terms"
            )
    extras = sorted(name for name in chosen if name.startswith(EXTRA_PREFIX))
    return (*(name for name in EFFECTS if name in chosen), *extras)
