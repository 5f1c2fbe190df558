"""Unit strings as files write them (CF/UDUNITS ``rad s-1``, ``m s-2``, ``degree_Celsius``;
people's ``deg/sec``, ``m/s**2``, ``µT``) read as the unit names ``--map`` knows
(:mod:`gyroid.io._units`), and which contract quantity such a unit measures."""

from __future__ import annotations

import re

#: Words and spellings for one unit, lower case -> the name gyroid's tables use.
_WORDS = {
    "radian": "rad", "radians": "rad", "rad": "rad", "mrad": "mrad", "milliradian": "mrad",
    "milliradians": "mrad", "degree": "deg", "degrees": "deg", "deg": "deg", "°": "deg",
    "mdeg": "mdeg", "millidegree": "mdeg", "millidegrees": "mdeg",
    "second": "s", "seconds": "s", "sec": "s", "secs": "s", "s": "s",
    "millisecond": "ms", "milliseconds": "ms", "ms": "ms", "microsecond": "us",
    "microseconds": "us", "us": "us", "nanosecond": "ns", "nanoseconds": "ns", "ns": "ns",
    "minute": "min", "minutes": "min", "min": "min", "hour": "h", "hours": "h", "hr": "h",
    "hrs": "h", "h": "h", "day": "d", "days": "d", "d": "d",
    "meter": "m", "meters": "m", "metre": "m", "metres": "m", "m": "m",
    "tesla": "T", "microtesla": "uT", "ut": "uT", "nanotesla": "nT", "nt": "nT",
    "millitesla": "mT", "mt": "mT", "gauss": "G", "milligauss": "mG", "mgauss": "mG",
    "kelvin": "K", "celsius": "degC", "fahrenheit": "degF",
}
#: Whole strings (after lower-casing and removing spaces) -> a unit name.
_WHOLE = {
    "degc": "degC", "deg_c": "degC", "degree_celsius": "degC", "degrees_celsius": "degC",
    "degreec": "degC", "degreesc": "degC", "°c": "degC", "c": "degC", "celsius": "degC",
    "degf": "degF", "degree_fahrenheit": "degF", "degrees_fahrenheit": "degF", "°f": "degF",
    "f": "degF", "k": "K", "kelvin": "K", "degk": "K", "dps": "deg/s", "dph": "deg/h",
    "mdps": "mdps", "g": "g", "g0": "g", "g_n": "g", "gn": "g", "gee": "g", "mg": "mg",
    "m/s2": "m/s^2", "m/s^2": "m/s^2", "ms-2": "m/s^2", "ms^-2": "m/s^2",
}
#: Single letters whose case is the unit: G gauss against g gravity, T tesla.
_CASED = {"G": "G", "T": "T", "g": "g", "mG": "mG", "uT": "uT", "nT": "nT", "mT": "mT"}


def canonical_unit(text: str | None) -> str | None:
    """``text`` as one of gyroid's unit names (``rad/s``, ``deg/h``, ``m/s^2``, ``g``,
    ``uT``, ``degC``, ``s``...), or None when it is none gyroid knows.

    >>> canonical_unit("rad s-1"), canonical_unit("degree_Celsius"), canonical_unit("m s-2")
    ('rad/s', 'degC', 'm/s^2')
    """
    if text is None:
        return None
    raw = str(text).strip().replace("µ", "u").replace("μ", "u").replace("**", "^")
    if not raw:
        return None
    if raw in _CASED:
        return _CASED[raw]
    squeezed = re.sub(r"\s+", "", raw.lower())
    if squeezed in _WHOLE:
        return _WHOLE[squeezed]
    if re.fullmatch(r"m(illi)?g", squeezed):
        return "mg"
    return _ratio(raw)


def _ratio(raw: str) -> str | None:
    """``num/den`` from ``a/b``, ``a per b``, ``a b-1``, ``a.b^-2`` forms."""
    text = re.sub(r"\s+per\s+", "/", raw.strip(), flags=re.IGNORECASE)
    numerator, denominator = [], []
    parts = text.split("/")
    for position, part in enumerate(parts):
        for token in re.split(r"[\s.*·]+", part.strip()):
            if not token:
                continue
            match = re.fullmatch(r"([A-Za-z°_]+)\^?(-?\d+)?", token)
            if match is None:
                return None
            word = _WORDS.get(match.group(1).lower())
            if word is None:
                return None
            power = int(match.group(2) or 1) * (-1 if position > 0 else 1)
            (numerator if power > 0 else denominator).append(
                word + (f"^{abs(power)}" if abs(power) != 1 else ""))
    if len(numerator) != 1 or len(denominator) > 1:
        return None
    name = numerator[0] + (f"/{denominator[0]}" if denominator else "")
    return {"deg/sec": "deg/s", "mdeg/s": "mdeg/s"}.get(name, name)


def quantity(unit: str | None) -> str | None:
    """What a canonical unit measures: ``rate``, ``acceleration``, ``field``,
    ``temperature``, ``time`` or None."""
    from gyroid.io._units import CONVERSIONS

    if unit is None:
        return None
    for kind, column in (("rate", "drift_deg_h"), ("acceleration", "ax_g"),
                         ("field", "Hx_uT"), ("temperature", "temperature_C")):
        if unit in CONVERSIONS[column]:
            return kind
    if unit in CONVERSIONS["time_s"] and unit != "datetime":
        return "time"
    return None
