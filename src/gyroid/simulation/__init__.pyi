"""Public names of :mod:`gyroid.simulation` for type checkers; at run time the package reads this
file (lazy_loader) and imports each name on first use."""

from ._bench import PAPER_A_DEVICE_2 as PAPER_A_DEVICE_2
from ._bench import PAPER_A_THERMAL as PAPER_A_THERMAL
from ._bench import MagneticProtocol as MagneticProtocol
from ._bench import SimulatedBench as SimulatedBench
from ._bench import ThermalProtocol as ThermalProtocol
from ._bench import simulate_magnetic_bench as simulate_magnetic_bench
from ._bench import simulate_thermal_bench as simulate_thermal_bench
from ._flight import FlightProfile as FlightProfile
from ._flight import SimulatedFlight as SimulatedFlight
from ._flight import roll_log_text as roll_log_text
from ._flight import simulate_flight as simulate_flight
from ._lot import SimulatedLot as SimulatedLot
from ._lot import simulate_lot as simulate_lot
from ._noise import GyroNoise as GyroNoise
from ._noise import gauss_markov as gauss_markov
from ._overload import OVERLOAD_TRUTH as OVERLOAD_TRUTH
from ._overload import OverloadProtocol as OverloadProtocol
from ._overload import simulate_overload_bench as simulate_overload_bench
from ._stream import StreamedBench as StreamedBench
from ._stream import stream_thermal_bench as stream_thermal_bench
