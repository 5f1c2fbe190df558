"""Paper A's classical estimators and the reproduction and audit of both papers' tables.
"""
