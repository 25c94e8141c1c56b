"""The SDN app: the controller logic (tables T1–T3, paths on ViSC requests, DR, SDC failover; pure,
``logic.py``) under a thin os-ken shim (``app.py``).
"""
