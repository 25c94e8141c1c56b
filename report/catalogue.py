"""Every experiment of the report, in the paper's order; the sweeps beyond the paper (B1, B2,
offline) after the paper's offline ones."""

from __future__ import annotations

from report.exp_cyber import C1, C2, C3, F1NET, F6NET, F9NET
from report.exp_delay import B1
from report.exp_delay_net import B1NET
from report.exp_grid import F3, F4, F5, F6
from report.exp_grid_net import F2NET, F3NET, F4NET, F7NET, F8NET
from report.exp_inertia_net import F5NET
from report.exp_network_model import NM
from report.exp_parallel import F8
from report.exp_programmable_h import F4H, F4HNET
from report.exp_sampling import B2
from report.exp_sdc import F1, F2
from report.exp_weak import F7, F9
from report.registry import INPUT, relabelled

# The kind of a claim declared in a module another engineer owns at the moment (report/exp_grid.py):
# move it into the declaration (``PaperClaim(..., kind=INPUT)``) when that module is next edited.
KINDS_DECLARED_HERE = {"F6.c": INPUT}  # the SDViSC's 1.5 p.u. limit is the law's i_max (sdc_unit/params.py)
EXPERIMENTS = relabelled((F1, F2, F3, F4, F4H, F5, F6, F7, F8, F9, B1, B2, NM, F1NET, F2NET, F3NET, F4NET, F4HNET, F5NET,
                          F6NET, F7NET, F8NET, F9NET, B1NET, C1, C2, C3), KINDS_DECLARED_HERE)  # offline first (fast, no network)
QUICK_NETWORK = ("F1net", "C2")  # what --quick (without --only) runs through the network: one grid, one cyber case
