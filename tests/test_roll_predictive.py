"""The predictive check of roll fits: a flight the model describes passes, a flight with an
effect the model leaves out that grows with time fails, its bands said to be too narrow."""

import pytest

from gyroid.io import RollLog
from gyroid.roll import RollProblem
from gyroid.roll._predictive import roll_predictive
from gyroid.simulation import FlightProfile, simulate_flight

SHORT = FlightProfile(duration_s=40.0)


@pytest.mark.parametrize("seed", [3, 4])
def test_a_flight_the_model_describes_is_predicted_within_its_bands(seed):
    flight = simulate_flight(params={"D0": 0.0, "Denc": 0.0}, profile=SHORT, seed=seed)
    problem = RollProblem.from_log(RollLog.from_columns(flight.columns), "ideal")
    check = roll_predictive(problem, problem.mode())
    assert check.passed, check.message
    assert "held out in 5 stretches of the flight" in check.message


def test_an_overloaded_stabiliser_fitted_as_ideal_is_not_predicted():
    """Paper B's overloaded stabiliser (its MEMS saturates, the platform turns): the ideal
    model's bands do not hold on the stretches it did not see."""
    flight = simulate_flight(params={"D0": 0.0, "Denc": 0.0}, seed=5, profile=FlightProfile(
        duration_s=40.0, gs_capacity_deg_s=2400.0))
    problem = RollProblem.from_log(RollLog.from_columns(flight.columns), "ideal")
    check = roll_predictive(problem, problem.mode())
    assert not check.passed and check.severity == "error", check.message
    assert "wider" in check.message and check.value > 2.0
