"""`python -m caustic_farm`: see `caustic_farm.cli`."""

import sys

from .cli import main

sys.exit(main())
