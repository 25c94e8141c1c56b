"""The paper report: every Section IV experiment of the SDViSC paper run on this testbed, figures
beside the paper's claims (``python -m report``; docs/report.md).

Floor 4 (beside ``benchmarks/``): it imports the plant, the SDC unit and, for the cyber-in-the-loop
experiments, nothing of ``scenarios/`` — those run the normal runner as a subprocess
(``python -m scenarios.cli run``) and read its ``summary.json`` and ``timeseries.csv``.
"""
