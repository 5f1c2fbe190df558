"""Paper A's benches and paper B's flights simulated with known truth, and gyro noise.
"""
