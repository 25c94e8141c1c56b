"""The claim sensitivity study (benchmarks/claim_sensitivity.py), one module per part: the shared
machinery (common), the sourced parameter ranges (ranges), the structural alternatives (structure),
the evaluations of the weak-grid claims (weak: F7, F9), of the fault claims (faults: F6.d, F8) and
of C1.b (c1), the claims (claims), the tornado study (study), its figures (figures) and the command
(cli)."""
