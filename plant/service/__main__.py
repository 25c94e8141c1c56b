"""``python -m plant.service --config FILE``: the plant service (:mod:`plant.service.main`)."""

import sys

from plant.service.main import main

sys.exit(main())
