"""``python -m modquad_gym.cli``: the ``modquad`` command."""

import sys

from . import main

sys.exit(main())
