"""The offshore wind-farm control centre (OWFCC) as a process of the lab: it asks the SDN application
for ViSC service and relays the scenario's requests (``python -m owfcc.service``)."""
