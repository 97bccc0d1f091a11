"""The input side of the pipeline: recorded joint telemetry, observed object poses and recording folders.

Everything here is read at the edge and validated once, so the simulation and inference layers can trust it.
"""
