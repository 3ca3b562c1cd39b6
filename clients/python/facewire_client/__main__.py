"""``python3 -m facewire_client``: the command line (produce, view, register, heads, batch)."""

import sys

from . import main

sys.exit(main())
