"""The plant simulator: the 50-turbine farm and its grid (network, turbines, condenser, battery, plant
controller) and its GTNET-SKT service.
"""
