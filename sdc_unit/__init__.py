"""The SDC unit: the ViSC law, its Tustin discretisation, the controller bank and the SDC service that
runs them over the network.
"""
