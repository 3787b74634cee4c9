"""The fresh process of :mod:`.recheck`: the success rows as JSON on its input, their verdicts
(a JSON list, "" for a confirmed row) as the last line of its output."""

from __future__ import annotations

import json
import sys

from modquad_gym.scoring.recheck import verdicts_of


def main() -> None:
    """Read the rows, print the verdicts."""
    given = json.load(sys.stdin)
    sources = {name: tuple(source) for name, source in given["sources"].items()}
    verdicts = verdicts_of(given["wins"], sources, given["n_max"], given["modules"], given["fault"])
    print(json.dumps(verdicts))


if __name__ == "__main__":
    main()
