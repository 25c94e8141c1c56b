"""Scenarios and their runner: the YAML schema, the Mininet run (processes, calibration, impairments,
interruptions), the CLI and live view, the summary.
"""
