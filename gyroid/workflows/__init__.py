"""What a user runs on a fit or a log: discrepancy (bench and roll, one loop), compensation,
propagation to dK, sensitivity, Allan deviation.
"""
