"""Variance-based (Sobol) sensitivity indices with grouped inputs.

Inputs come in independent groups (a group may be a whole posterior draw, whose
coefficients are correlated among themselves). With two independent sample sets A and B of
size N and, for each group i, the set AB_i (A with group i taken from B):

* first-order index ``S_i = mean(f(B) (f(AB_i) - f(A))) / V`` (Saltelli 2010),
* total index ``ST_i = mean((f(A) - f(AB_i))**2) / (2 V)`` (Jansen 1999),

with ``V`` the variance of f over A and B together. Cost: ``N (k + 2)`` evaluations.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

Sampler = Callable[[np.random.Generator, int], np.ndarray]


def sobol_indices(
    groups: Mapping[str, Sampler],
    evaluate: Callable[[dict[str, np.ndarray]], np.ndarray],
    n: int,
    rng: np.random.Generator,
) -> dict[str, dict[str, float]]:
    """First-order and total Sobol indices of ``evaluate`` for each input group.

    ``groups[name](rng, n)`` returns ``n`` samples of that group (first axis);
    ``evaluate(inputs)`` maps a dict of such arrays to ``n`` outputs.
    """
    a = {name: sample(rng, n) for name, sample in groups.items()}
    b = {name: sample(rng, n) for name, sample in groups.items()}
    f_a, f_b = np.asarray(evaluate(a)), np.asarray(evaluate(b))
    variance = float(np.var(np.concatenate([f_a, f_b])))
    out: dict[str, dict[str, float]] = {}
    for name in groups:
        mixed = dict(a)
        mixed[name] = b[name]
        f_ab = np.asarray(evaluate(mixed))
        if variance == 0.0:
            out[name] = {"S1": 0.0, "ST": 0.0}
            continue
        out[name] = {
            "S1": float(np.mean(f_b * (f_ab - f_a)) / variance),
            "ST": float(np.mean((f_a - f_ab) ** 2) / (2.0 * variance)),
        }
    return out
