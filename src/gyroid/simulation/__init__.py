"""Paper A's benches and paper B's flights simulated with known truth, and gyro noise.
"""

from gyroid.simulation._bench import (
    PAPER_A_DEVICE_2,
    PAPER_A_THERMAL,
    MagneticProtocol,
    SimulatedBench,
    ThermalProtocol,
    simulate_magnetic_bench,
    simulate_thermal_bench,
)
from gyroid.simulation._flight import (
    FlightProfile,
    SimulatedFlight,
    roll_log_text,
    simulate_flight,
)
from gyroid.simulation._lot import (
    SimulatedLot,
    simulate_lot,
)
from gyroid.simulation._noise import (
    GyroNoise,
    gauss_markov,
)

__all__ = [
    "FlightProfile",
    "GyroNoise",
    "MagneticProtocol",
    "PAPER_A_DEVICE_2",
    "PAPER_A_THERMAL",
    "SimulatedBench",
    "SimulatedFlight",
    "SimulatedLot",
    "ThermalProtocol",
    "gauss_markov",
    "roll_log_text",
    "simulate_flight",
    "simulate_lot",
    "simulate_magnetic_bench",
    "simulate_thermal_bench",
]
