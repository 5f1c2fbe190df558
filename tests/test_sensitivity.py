"""Sobol indices validated on the Ishigami function, whose indices are known exactly."""

import numpy as np
import pytest

from gyroid.workflows import sobol_indices

A, B = 7.0, 0.1
# Exact indices of f = sin x1 + a sin^2 x2 + b x3^4 sin x1, x_i ~ U(-pi, pi).
V1 = 0.5 * (1 + B * np.pi**4 / 5) ** 2
V2 = A**2 / 8
V13 = B**2 * np.pi**8 * (1 / 18 - 1 / 50)
V = V1 + V2 + V13
EXACT = {"x1": (V1 / V, (V1 + V13) / V), "x2": (V2 / V, V2 / V), "x3": (0.0, V13 / V)}


def _uniform(rng, n):
    return rng.uniform(-np.pi, np.pi, n)


def test_ishigami_indices():
    def f(x):
        return np.sin(x["x1"]) + A * np.sin(x["x2"]) ** 2 + B * x["x3"] ** 4 * np.sin(x["x1"])

    indices = sobol_indices({k: _uniform for k in ("x1", "x2", "x3")}, f, 200_000,
                            np.random.default_rng(1))
    for name, (s1, st) in EXACT.items():
        # Monte-Carlo error of these estimators at N = 2e5 is below 0.01.
        assert indices[name]["S1"] == pytest.approx(s1, abs=0.02), name
        assert indices[name]["ST"] == pytest.approx(st, abs=0.02), name
    assert sum(v["S1"] for v in indices.values()) <= 1.02


def test_grouped_inputs_with_correlation():
    # y = u + v + w with (u, v) one correlated group: the group carries var(u + v).
    def group(rng, n):
        u = rng.normal(size=n)
        return np.column_stack([u, u + 0.5 * rng.normal(size=n)])

    def f(x):
        return x["uv"][:, 0] + x["uv"][:, 1] + x["w"]

    indices = sobol_indices({"uv": group, "w": lambda r, n: r.normal(size=n)}, f, 100_000,
                            np.random.default_rng(2))
    var_uv = 4.25  # var(2u + 0.5 e)
    assert indices["uv"]["S1"] == pytest.approx(var_uv / (var_uv + 1), abs=0.02)
    assert indices["w"]["ST"] == pytest.approx(1 / (var_uv + 1), abs=0.02)
