"""``python -m bt_servicesim`` is ``python -m bt_servicesim.run``."""

import sys

from bt_servicesim.mission.shutdown_limit import SHUTDOWN_LIMIT_S
from bt_servicesim.run import main

sys.exit(main(shutdown_limit_s=SHUTDOWN_LIMIT_S))
