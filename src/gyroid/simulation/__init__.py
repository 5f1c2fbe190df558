"""Paper A's benches and paper B's flights simulated with known truth, and gyro noise.
"""

from gyroid._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_bench": [
        "PAPER_A_DEVICE_2", "PAPER_A_THERMAL", "MagneticProtocol", "SimulatedBench",
        "ThermalProtocol", "simulate_magnetic_bench", "simulate_thermal_bench",
    ],
    "_flight": ["FlightProfile", "SimulatedFlight", "roll_log_text", "simulate_flight"],
    "_lot": ["SimulatedLot", "simulate_lot"],
    "_noise": ["GyroNoise", "gauss_markov"],
    "_overload": ["OVERLOAD_TRUTH", "OverloadProtocol", "simulate_overload_bench"],
    "_stream": ["StreamedBench", "stream_thermal_bench"],
})
