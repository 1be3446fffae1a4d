"""Datasets: the Sequence record, loaders for real recorded sets, the synthetic omni world.

Loaders convert every convention once, at the edge, into the records of ``omnislam.core``.
"""
