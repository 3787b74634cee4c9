"""Re-render seeds reports from their ``seeds.csv``, without scoring any model again.

    python -m benchmarks.seeds_rerender results/seeds_current [FOLDER ...] --force

Each FOLDER's ``seeds.md`` and ``seeds.png`` are written as ``python -m
modquad_gym.scoring.seeds`` now writes them (:mod:`modquad_gym.scoring.seeds_report`), from the
scores in its ``seeds.csv``; the scoring run's command, machine, wall time and runs are kept
from the old ``seeds.md``, the re-rendering named beside them. Every folder is read and checked
before any is written; the files are replaced only with ``--force``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from benchmarks.common import Distinct, HelpFormatter, read_input_text, read_rows_csv, run_main
from modquad_gym.core.options import OneLineParser, path_option
from modquad_gym.core.outputs import write_text


def read_folder(folder: Path) -> tuple[list, str]:
    """(scores of ``folder/seeds.csv``, ``folder/seeds.md``'s text); a one-line ValueError
    naming the file otherwise."""
    from modquad_gym.scoring.seed_scores import SeedScore

    columns = [f.name for f in dataclasses.fields(SeedScore)]
    what = "a seeds.csv of python -m modquad_gym.scoring.seeds"
    scores = read_rows_csv(folder / "seeds.csv", "FOLDER", columns, SeedScore.from_record, what,
                           older=(columns[:-1],))  # fmt: skip
    if not any(s.seed != "-" for s in scores):
        raise ValueError(f"FOLDER {folder / 'seeds.csv'}: no learned method's seed")
    return scores, read_input_text(folder / "seeds.md", "FOLDER")


def main(argv: list[str] | None = None) -> int:

    from modquad_gym.scoring.seeds_report import plot, rerendered

    parser = OneLineParser(
        prog="python -m benchmarks.seeds_rerender",
        description=__doc__.split("\n\n")[0],
        formatter_class=HelpFormatter,
    )
    parser.add_argument(
        "folders",
        nargs="+",
        type=path_option,
        action=Distinct,
        key=Path.resolve,
        metavar="FOLDER",
        help="seeds report folders (seeds.csv, seeds.md)",
    )
    parser.add_argument("--force", action="store_true", help="replace seeds.md and seeds.png")
    args = parser.parse_args(argv)
    texts = []
    for folder in args.folders:  # every folder checked before any is written
        try:
            scores, old = read_folder(folder)
            command = f"python -m benchmarks.seeds_rerender {folder} --force"
            texts.append((folder, scores, rerendered(scores, old, command)))
        except ValueError as exc:
            parser.error(str(exc) if str(exc).startswith("FOLDER") else f"FOLDER {folder}: {exc}")
    if not args.force:
        parser.error(f"--force: {args.folders[0] / 'seeds.md'} exists; replace it with --force")
    for folder, scores, text in texts:
        write_text(folder / "seeds.md", text)
        plot(scores, folder / "seeds.png")
        print(f"re-rendered {folder / 'seeds.md'} and seeds.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "seeds_rerender"))
