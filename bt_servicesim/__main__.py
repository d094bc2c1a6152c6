"""``python -m bt_servicesim`` is ``python -m bt_servicesim.run``."""

import sys

from bt_servicesim.run import main

sys.exit(main())
