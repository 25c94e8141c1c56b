"""The plant as a network service (``python -m plant.service --config FILE``): the GTNET-SKT endpoints
(:mod:`.endpoint_rx`, :mod:`.endpoint_tx`), the paced core (:mod:`.core`), the model it steps through
the one backend interface (:mod:`.model`, :mod:`plant.backend`: the phasor plant, the infinite-bus
minimal model or the EMT backend), the live status (:mod:`.live`), the recorder (:mod:`.recorder`),
the summary (:mod:`.summary`) and the run record read back afterwards (:mod:`.run_record`); the
process itself in :mod:`.main`."""
