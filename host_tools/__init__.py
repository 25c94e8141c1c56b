"""Tools for the machine the lab runs on, not parts of the farm: cleanup of what a run leaves behind,
Open vSwitch's CPU split, the capture decoder (``sdvisc pcap``) and the hostile-traffic sender of the
scenarios' ``fuzz`` events."""
