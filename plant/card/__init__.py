"""The project's GTNET-SKT card emulator (``python -m plant.card.emulator --config FILE``, ``sdvisc gtnet-card``):
an RTDS with GTNET-SKT cards run as a program of its own, in place of the testbed's plant. The
paced sockets in :mod:`.emulator`, the decisions (pure code) in :mod:`.core`, the misbehaviours it
can be told to show in :mod:`.faults`. It speaks through the plant service's endpoints
(:mod:`plant.service.endpoint_rx`, :mod:`plant.service.endpoint_tx`) and steps the minimal model."""
