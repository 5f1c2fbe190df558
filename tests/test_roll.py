"""Paper B's roll-correction loop: against a NumPy loop, gradients, closed forms, limits."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from gyroid.models import Flight, RollParams, constant_flight, run_loop
from gyroid.models import _paper_b as pb


def _numpy_loop(params: dict, w, w_h, drift, noise, gs_noise, dt, period, rng_deg, phase,
                feedback):
    """The same loop written plainly, sample by sample."""
    n = w.size
    m = int(round(period / dt))
    true = sins_int = plat = 0.0
    gs_prev = params["Denc"] * np.sin(phase)
    K = 1.0
    raw_sum = 0.0
    corrected = 0.0
    out_err, out_k = [], []
    for k in range((n // m) * m):
        true += w[k] * dt
        scale = 1 + params["D1"] + params["D2"] * abs(w[k]) / 1000
        wx = params["D0"] + drift[k] + scale * w[k] + noise[k]
        mems = min(max(params["D0gs"] + (1 + params["D1gs"]) * w_h[k], -rng_deg), rng_deg)
        plat += (mems - w_h[k]) * dt
        raw_sum += wx * dt
        corrected += K * wx * dt
        sins_int += wx * dt
        out_err.append(corrected - true)
        if (k + 1) % m == 0:
            gs = true + plat + params["Denc"] * np.sin(true * np.pi / 180 + phase) + gs_noise[k]
            applied = K * raw_sum if feedback else raw_sum
            estimate = (applied - (gs - gs_prev)) / applied
            K = K * (1 - estimate) if feedback else 1 - estimate
            out_k.append(K)
            gs_prev = gs
            raw_sum = 0.0
    return np.array(out_err), np.array(out_k)


@pytest.mark.parametrize("feedback", [False, True])
def test_scan_model_matches_a_plain_numpy_loop(feedback):
    rng = np.random.default_rng(3)
    dt, period, n = 0.01, 2.0, 2000
    t = dt * np.arange(n)
    w = 900.0 + 300.0 * np.sin(t / 3.0)
    w_h = 250.0 + 60.0 * np.sin(t)  # crosses the 300 deg/s saturation now and then
    drift = 0.01 * np.sin(t / 7.0)
    noise = rng.normal(0, 0.05, n)
    gs_noise = rng.normal(0, 0.01, n)
    params = {"D0": 0.002, "D1": 6e-4, "D0gs": 3.3e-3, "D1gs": 2.8e-4, "Denc": 0.33,
              "D2": 1e-5}
    flight = Flight(jnp.asarray(w), jnp.asarray(w_h), jnp.asarray(drift), jnp.asarray(noise),
                    jnp.asarray(gs_noise), sample_s=dt, period_s=period, mems_range_deg_s=300.0,
                    feedback=feedback)
    result = run_loop(RollParams(**params, encoder_phase=0.4), flight)
    error, K = _numpy_loop(params, w, w_h, drift, noise, gs_noise, dt, period, 300.0, 0.4,
                           feedback)
    np.testing.assert_allclose(np.asarray(result.K), K, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(result.angle_error_deg), error, rtol=0, atol=1e-9)


def test_gradients_match_finite_differences():
    flight = constant_flight(913.0, 30.0, sample_s=5e-3, period_s=5.0,
                             uncompensated_deg_s=200.0)

    def objective(theta):
        params = RollParams(D0=theta[0], D1=theta[1], D0gs=theta[2], D1gs=theta[3],
                            Denc=theta[4])
        result = run_loop(params, flight)
        return jnp.mean(result.dK) + 1e-3 * result.angle_error_deg[-1]

    theta = jnp.asarray([0.01, 6e-4, 3.3e-3, 2.8e-4, 0.33])
    grad = np.asarray(jax.grad(objective)(theta))
    for i in range(theta.size):
        h = 1e-4 * max(abs(float(theta[i])), 1e-6)
        e = jnp.zeros_like(theta).at[i].set(h)
        fd = (objective(theta + e) - objective(theta - e)) / (2 * h)
        assert grad[i] == pytest.approx(float(fd), rel=1e-5, abs=1e-10), i


def test_ideal_stabiliser_agrees_with_eq5():
    # Encoder error off: the per-period error is exactly D0gs dt / (w dt).
    params = RollParams(D0=0.0, Denc=0.0)
    result = run_loop(params, constant_flight(900.0, 60.0))
    # Exactly eq. 5 with the true rate in the denominator; with the measured w_x = (1 + D1) w
    # that the paper writes, within D1 relative.
    np.testing.assert_allclose(np.asarray(result.dK), pb.dk_ideal(3.3e-3, 0.0, 900.0, 5.0),
                               rtol=1e-8)
    measured = pb.dk_ideal(3.3e-3, 0.0, 900.0 * (1 + 600e-6), 5.0)
    np.testing.assert_allclose(np.asarray(result.dK), measured, rtol=1.01 * 600e-6)
    # Most of the SF error is removed: residual SF error is D0gs / w, 3.7 ppm of 600.
    assert np.all(np.abs(np.asarray(result.residual_sf_error)) < 0.01 * 600e-6)
    assert abs(float(result.angle_error_deg[-1])) < 0.1 * abs(
        float(result.uncorrected_error_deg[-1]))


def test_encoder_error_spread_matches_eq5_scale():
    # The encoder error enters as Denc (sin a_i - sin a_{i-1}), a_i the roll angle at the end
    # of period i. At a constant rate the angle advances by delta per period, and over many
    # periods (phases equidistributed) the increments' RMS is Denc sqrt(1 - cos delta): the
    # size eq. 5 assumes (Denc) at delta = 90 deg, up to 1.41 Denc at 180 deg.
    params = RollParams(D0gs=0.0, Denc=0.33)
    rate = 913.7
    result = run_loop(params, constant_flight(rate, 2000.0, sample_s=2e-2))
    dk = np.asarray(result.dK)
    delta = np.deg2rad((rate * 5.0) % 360.0)
    expected = 0.33 * np.sqrt(1 - np.cos(delta)) / (rate * 5.0)
    assert dk.size == 400
    assert np.sqrt(np.mean(dk**2)) == pytest.approx(expected, rel=0.01)
    assert 0.5 < expected / pb.dk_ideal(0.0, 0.33, rate, 5.0) < 1.5


def test_overloaded_stabiliser_agrees_with_eq7_until_saturation():
    params = RollParams(D0=0.0, Denc=0.0)
    loop = run_loop(params, constant_flight(900.0, 30.0, uncompensated_deg_s=300.0))
    eq7 = pb.dk_overloaded(3.3e-3, 280e-6, 300.0, 0.0, 900.0, 5.0)
    np.testing.assert_allclose(np.asarray(loop.dK), eq7, rtol=1e-8)
    # The correction still removes most of the SF error, but less than with an ideal GS.
    # The residual SF error after correction, K (1 + D1) - 1, is dK itself.
    np.testing.assert_allclose(np.asarray(loop.residual_sf_error), np.asarray(loop.dK),
                               rtol=1e-12)
    ideal = run_loop(params, constant_flight(900.0, 30.0))
    assert float(loop.dK[0]) > 20 * float(ideal.dK[0])
    # Beyond the MEMS range the stabiliser saturates and eq. 7 no longer holds.
    saturated = run_loop(params, constant_flight(900.0, 30.0, uncompensated_deg_s=400.0))
    expected = (330.0 - 400.0) / 900.0
    assert float(saturated.dK[0]) == pytest.approx(expected, rel=1e-3)
    assert abs(float(saturated.dK[0])) > 100 * pb.dk_overloaded(3.3e-3, 280e-6, 400.0, 0.0,
                                                                 900.0, 5.0)


def test_eq5_breaks_when_d0_is_not_small():
    # D0 = 0.5 deg/s is comparable with D1 w = 0.54 deg/s: the loop takes D0 for SF error.
    params = RollParams(D0=0.5, Denc=0.0)
    result = run_loop(params, constant_flight(900.0, 30.0))
    eq5 = pb.dk_ideal(3.3e-3, 0.0, 900.0, 5.0)
    dk = float(result.dK[0])
    assert abs(dk) > 100 * eq5
    # Exactly: dK = (D0gs (1 + D1) - D0) / (D0 + (1 + D1) w).
    assert dk == pytest.approx((3.3e-3 * (1 + 6e-4) - 0.5) / (0.5 + (1 + 6e-4) * 900.0),
                               rel=1e-9)


def test_lateral_error_limits_and_eq8():
    t = np.array([10.0, 60.0, 120.0])
    exact = pb.lateral_error_exact_m(600e-6, 3600.0, t)
    eq8 = pb.lateral_error_eq8_m(600e-6, 3600.0, t)
    bound = pb.lateral_error_bound_m(t)
    assert np.all(exact <= bound)
    # Small angles (10 s, 21.6 deg): eq. 8 within 1 %; large angles: eq. 8 fails badly,
    # beyond even the physical bound at 120 s.
    assert eq8[0] == pytest.approx(exact[0], rel=0.01)
    assert eq8[1] > 1.2 * exact[1]
    assert eq8[2] > bound[2]
    # The closed form equals g sin(D1 w t) integrated twice numerically.
    dt = 1e-3
    time = dt * np.arange(1, 120001)
    accel = pb.G * np.sin(600e-6 * 3600.0 * time * pb.DEG)
    position = np.cumsum(np.cumsum(accel) * dt) * dt
    # (Euler sums with 1 ms steps: relative error of order a few dt / t.)
    np.testing.assert_allclose(position[[9999, 59999, 119999]], exact, rtol=1e-3)
    # The loop's lateral error of the corrected SINS never exceeds the bound either.
    loop = run_loop(RollParams(D0=2.0), constant_flight(3600.0, 60.0))
    lateral = np.abs(np.asarray(loop.lateral_error_m))
    assert np.all(lateral <= pb.lateral_error_bound_m(np.asarray(loop.time_s)) * (1 + 1e-9))


def test_paper_b_tables_recomputed():
    table = pb.table2()
    assert [table[k]["dpsi_deg"] for k in ("10", "60", "120")] == pytest.approx(
        [21.6, 129.6, 259.2])
    assert table["10"]["dr_z_m_eq8"] == pytest.approx(61.6, abs=0.05)
    assert table["60"]["dr_z_bound_m"] == pytest.approx(17652, abs=1)
    # The printed dr_z is g D1 w_x t^3 with w_x in deg/s, no 1/6, in km (0.3 % off).
    for k in table:
        assert table[k]["dr_z_printed"] == pytest.approx(
            table[k]["dr_z_printed_reconstruction"], rel=0.005)
    gs = pb.table_gs()
    assert [gs[k]["dpsi_gs_deg"] for k in ("10", "60", "120")] == pytest.approx(
        [0.363, 0.528, 0.726])
    worked = pb.dk_worked()
    assert worked["recomputed"] == pytest.approx(1.70e-4, rel=0.01)
    assert worked["printed_reconstruction"] == pytest.approx(0.093, abs=0.0005)
    assert pb.mems_bias_deg_s() * 3600 == pytest.approx(12.2, abs=0.01)


def _busy_flight(seed: int, n: int, rate: float, period_s: float) -> tuple[RollParams, Flight]:
    """A varying roll rate, an overloaded stabiliser, drift and noise on every signal, and
    every loop parameter non-zero: where a fast path could part from the full loop."""
    rng = np.random.default_rng(seed)
    t = 0.01 * np.arange(n)
    flight = Flight(jnp.asarray(rate + 0.4 * rate * np.sin(t / 4)),
                    jnp.asarray(250 + 60 * np.cos(t)), jnp.asarray(0.01 * np.sin(t / 5)),
                    jnp.asarray(rng.normal(0, 0.05, n)), jnp.asarray(rng.normal(0, 0.01, n)),
                    sample_s=0.01, period_s=period_s)
    params = RollParams(D0=0.01 * seed, D1=7e-4 + 1e-4 * seed, D0gs=3e-3, D1gs=3e-4,
                        Denc=0.33 / seed, D2=1e-5 * seed, encoder_phase=1.1 / seed)
    return params, flight


def test_period_sums_fast_path_equals_the_full_loop():
    from gyroid.models import correction_coefficients

    params, flight = _busy_flight(1, 3000, 1500.0, 3.0)
    np.testing.assert_allclose(np.asarray(correction_coefficients(params, flight)),
                               np.asarray(run_loop(params, flight).dK), rtol=1e-9, atol=1e-12)


def test_navigation_errors_at_report_samples_equal_the_full_loop():
    from gyroid.models import navigation_errors

    params, flight = _busy_flight(2, 4000, 1200.0, 2.5)
    full = run_loop(params, flight)
    idx = jnp.asarray([0, 999, 2500, 3999])  # 4000 samples: the last period ends at 3999
    fast = jax.jit(navigation_errors)(params, flight, idx)
    np.testing.assert_allclose(fast.dK, full.dK, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fast.residual_sf_error, full.residual_sf_error, rtol=1e-9,
                               atol=1e-12)
    # The full loop differences two large cumulative angles (~5e4 deg): agreement to its
    # rounding, ~1e-11 relative.
    np.testing.assert_allclose(fast.angle_error_deg, full.angle_error_deg[idx], rtol=1e-7,
                               atol=1e-8)
    np.testing.assert_allclose(fast.lateral_error_m, full.lateral_error_m[idx], rtol=1e-7,
                               atol=1e-9)
    assert float(fast.peak_mems_deg_s) == pytest.approx(float(jnp.max(jnp.abs(
        full.gs_rate_deg_s))))
    assert np.all(np.abs(np.asarray(fast.lateral_error_m)[1:]) > 0)
    # A flight that ends inside a period: the loop stops at the last whole period, and a
    # report sample after it reads that end, as indexing run_loop's histories does.
    short = constant_flight(900.0, 23.0, sample_s=0.01)
    ended = run_loop(params, short)
    late = navigation_errors(params, short, jnp.asarray([500, 2299]))
    n = ended.lateral_error_m.shape[0]
    assert n < short.n
    expected = ended.lateral_error_m[jnp.asarray([500, n - 1])]
    np.testing.assert_allclose(late.lateral_error_m, expected, rtol=1e-7)
