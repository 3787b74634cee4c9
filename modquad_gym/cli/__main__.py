"""``python -m modquad_gym.cli``: the ``modquad`` command."""

import sys

from modquad_gym.cli import main

sys.exit(main())
