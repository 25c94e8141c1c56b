"""The EMT backend on DPsim (issue 40, offline core): the paper's comparison arrangement (Section IV-B)
in three-phase electromagnetic transients, stepped from Python.

* :mod:`plant.emt.dpsim_env`: imports ``dpsimpy`` (the optional ``emt`` extra, PyPI ``dpsim``) with its
  files (``$HOME/OpenDSS``, ``./logs``) sent to a temporary directory;
* :mod:`plant.emt.frame`: the Park transform in the common frame, per-phase RMS, the YNd current transform;
* :mod:`plant.emt.arrangement`: the circuit (grid Thevenin source, the farm's injection, the SC's or the
  SDViSC's step-up, the YNd zero-sequence paths, the fault switch) and its operating point, taken from
  the phasor plant (``plant.cases``) so that both models start from the same load flow;
* :mod:`plant.emt.devices`: the per-Ts controllers (SC rotor + AVR, the SDViSC's ViSC law, the farm's
  grid-following injection);
* :mod:`plant.emt.model`: :class:`~plant.emt.model.EmtComparison`, the stepped run with events.
"""

FARM_VISC_HOSTS = ("wt3_1", "wt3_2", "wt3_3", "wt3_4")
"""The SDViSCs of F8's farm arrangement (cluster 3, :mod:`plant.emt.farm_service`): here, without any
import, so that the scenario loader checks a scenario against them without loading DPsim."""
