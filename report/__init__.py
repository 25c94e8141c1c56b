"""The paper report: every Section IV experiment of the SDViSC paper run on this testbed, figures
beside the paper's claims (``python -m report``; docs/report.md).

Floor 4 (beside ``benchmarks/``): it imports the plant and the SDC unit; the cyber-in-the-loop
experiments run the normal runner as a subprocess (``python -m scenarios.cli run``) and read its
``summary.json`` and ``timeseries.csv``. Of ``scenarios/`` it imports two constants only: the switch
port types its ``--switch-ports`` offers (``__main__``) and the calibration's candidate time scales
(``network_runs``).
"""
