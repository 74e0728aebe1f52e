"""Independent ground truth rendered with Mitsuba 3.

`data_gen` imports `attenfit` (for its emitters and `Dataset` format); `attenfit` never
imports `data_gen`.
"""
