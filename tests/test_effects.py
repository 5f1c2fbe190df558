"""The effects registry and the drift model: contract names, linearity, gradients."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import SHORT_MAGNETIC

from gyroid import CANDIDATES, EFFECTS, PRESETS, DriftModel, GyroidInputError, resolve_terms
from gyroid.models import PARAMETERS
from gyroid.simulation import GyroNoise, simulate_magnetic_bench, simulate_thermal_bench

CONTRACT_PARAMETERS = {
    "bias": ("w0",),
    "temperature": ("w1",),
    "temperature_sq": ("w2",),
    "temperature_rate": ("wD",),
    "magnetic_x": ("wx",),
    "magnetic_y": ("wy",),
    "magnetic_z": ("wz",),
    **{f"overload_{a}": (f"n{a}",) for a in "xyz"},  # section 6
    **{f"overload_sq_{a}": (f"n{a}{a}",) for a in "xyz"},
}
CONTRACT_CANDIDATES = {
    "thermal_lag",
    "warmup",
    "time_trend",
    "magnetic_hysteresis",
    "bias_step",
    "temperature_cubic",
}


def test_registry_follows_the_contract():
    for name, params in CONTRACT_PARAMETERS.items():
        assert EFFECTS[name].parameter_names == params
        assert EFFECTS[name].paper
    assert CONTRACT_CANDIDATES <= set(CANDIDATES)  # the contract's, and gyroid's own
    assert set(CANDIDATES) - CONTRACT_CANDIDATES == {"thermal_hysteresis"}
    assert PRESETS["thermal"] == ("bias", "temperature", "temperature_sq", "temperature_rate")
    assert PRESETS["magnetic"] == ("bias", "magnetic_x", "magnetic_y", "magnetic_z")
    assert set(PRESETS["full"]) == set(PRESETS["thermal"]) | set(PRESETS["magnetic"])
    assert PRESETS["overload"] == ("bias", "overload_x", "overload_y", "overload_z")
    names = [p.name for e in EFFECTS.values() for p in e.parameters]
    assert len(names) == len(set(names)), "parameter names must be unique"
    for p in PARAMETERS.values():
        assert p.unit and p.description


def test_resolve_terms_expands_presets_and_refuses_unknown_names():
    assert resolve_terms("magnetic,time_trend") == (
        "bias",
        "magnetic_x",
        "magnetic_y",
        "magnetic_z",
        "time_trend",
    )
    # full is paper A's thermal and magnetic models (contract); eq. 1's overload is its own
    assert resolve_terms("full") == tuple(n for n in EFFECTS if EFFECTS[n].paper
                                          and not n.startswith("overload"))
    assert resolve_terms("overload") == ("bias", "overload_x", "overload_y", "overload_z")
    with pytest.raises(GyroidInputError, match="unknown term 'temprature'"):
        resolve_terms("bias,temprature")
    with pytest.raises(GyroidInputError, match="add temperature"):
        resolve_terms("bias,thermal_lag")


@pytest.fixture(scope="module")
def rich_inputs():
    """Inputs in which every effect is active: a short thermal run plus a field sweep and a
    tumble's specific force."""
    sim = simulate_thermal_bench(
        seed=3, noise=GyroNoise(), protocol=__import__("helpers").SHORT_THERMAL
    )
    mag = simulate_magnetic_bench(seed=3, protocol=SHORT_MAGNETIC)
    n = sim.log.n
    columns = dict(sim.log.columns)
    for name in ("Hx_uT", "Hy_uT", "Hz_uT"):
        columns[name] = np.resize(mag.log.columns[name], n)
    from gyroid.simulation import OverloadProtocol, simulate_overload_bench

    tumble = simulate_overload_bench(seed=3, protocol=OverloadProtocol(dwell_min=5.0))
    for name in ("ax_g", "ay_g", "az_g"):
        columns[name] = np.resize(tumble.log.columns[name], n)
    from gyroid.models import build_inputs

    return build_inputs(columns)


@pytest.mark.parametrize("effect", list(EFFECTS))
def test_gradient_matches_finite_differences(effect, rich_inputs):
    terms = resolve_terms(
        [effect, "temperature", "temperature_sq"] if effect == "thermal_lag" else [effect]
    )
    model = DriftModel(terms=terms)
    rng = np.random.default_rng(7)
    theta = []
    for p in model.parameters:
        theta.append(rng.uniform(5.0, 30.0) if p.positive else rng.normal(0.0, 0.5))
    theta = jnp.asarray(theta)
    weights = jnp.asarray(rng.normal(size=rich_inputs.n))

    def objective(th):
        return jnp.sum(weights * model.predict(th, rich_inputs))

    grad = np.asarray(jax.grad(objective)(theta))
    for i, p in enumerate(model.parameters):
        h = 1e-5 * max(1.0, abs(float(theta[i])))
        e = jnp.zeros_like(theta).at[i].set(h)
        fd = (objective(theta + e) - objective(theta - e)) / (2 * h)
        assert grad[i] == pytest.approx(float(fd), rel=1e-6, abs=1e-6), p.name


@pytest.mark.parametrize("effect", [n for n, e in EFFECTS.items() if e.linear])
def test_linear_effects_design_reproduces_the_model(effect, rich_inputs):
    model = DriftModel(terms=(effect,))
    theta = jnp.asarray(np.linspace(-1.0, 2.0, len(model.parameter_names)))
    direct = model.predict(theta, rich_inputs)
    np.testing.assert_allclose(model.design(rich_inputs) @ theta, direct, rtol=1e-12)


def test_thermal_lag_is_the_temperature_terms_on_the_lagged_temperature(rich_inputs):
    from gyroid.models import lagged_temperature

    model = DriftModel.from_terms("bias,temperature,temperature_sq,thermal_lag")
    params = {"w0": 0.3, "w1": -0.1, "w2": 0.004, "tau_lag_min": 12.0}
    lagged = lagged_temperature(rich_inputs.time_h, rich_inputs.temperature_C, 12.0 / 60.0)
    t = lagged - rich_inputs.t0_C
    expected = 0.3 - 0.1 * t + 0.004 * t**2
    np.testing.assert_allclose(model(params, rich_inputs), expected, rtol=1e-12, atol=1e-12)


def test_model_is_float64(rich_inputs):
    model = DriftModel.from_terms("full")
    out = model.predict(jnp.ones(len(model.parameter_names)), rich_inputs)
    assert out.dtype == jnp.float64


def test_a_bias_step_and_an_extra_column_effect_contribute_as_documented():
    import numpy as np

    from gyroid.models import build_inputs, effect

    t = np.arange(0.0, 36000.0, 10.0)  # 10 h
    pressure = np.sin(t / 3000.0)
    x = build_inputs({"time_s": t, "pressure": pressure}, extra_columns=("pressure",))
    step = np.asarray(effect("bias_step").contribution({"w_step": 0.5, "t_step_h": 4.0}, x))
    hours = t / 3600.0
    # A logistic edge of 1/200 of the log (3 min): 0 well before, 0.5 well after, half at 4 h.
    assert np.allclose(step[hours < 3.0], 0.0, atol=1e-6)  # 20 edge widths: e^-20
    assert np.allclose(step[hours > 5.0], 0.5, atol=1e-6)
    assert abs(step[np.argmin(abs(hours - 4.0))] - 0.25) < 1e-9
    extra = np.asarray(effect("extra:pressure").contribution({"w_extra_pressure": 2.0}, x))
    assert np.allclose(extra, 2.0 * (pressure - pressure.mean()))
