"""The files of a validation in its folder: the folder held for the run (:func:`hold_out_dir`)
and ``report.md`` with ``validation.json``, composed once and written once (:class:`ReportPage`).

A validation's page (:func:`.report_markdown.markdown`) takes sections from flights flown after
its own: a dynamic task's flight along its trajectory (its task headline and its section,
:mod:`.validate_track`) and the flights through a failure (``modquad validate --fault``,
:func:`.validate_fault.add_to_report`). :class:`ReportPage` keeps the parts until the last
flight is done; :meth:`ReportPage.write` then composes the page and writes it with the record,
each file once, so that no writer reads back and rewrites another's file.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from modquad_gym.core.outputs import claim_output_dir, hold_output_dir, write_text
from modquad_gym.core.validation import check_flag

REPORT_FILES = ("report.md", "validation.json")
"""The page and the record, in the order :meth:`ReportPage.write` writes them."""


@contextmanager
def hold_out_dir(out_dir: str | Path | None, names: tuple[str, ...], force: bool,
                 what: str = "out_dir") -> Iterator[Path | None]:  # fmt: skip
    """Hold ``out_dir`` for one validation, as both doors (:func:`.validate.validate` and
    ``modquad validate --out``, ``what`` naming it) hold it, before any simulation: a file there
    of one of ``names`` (what the run writes) is an OutputError unless ``force``, and so is a
    folder that is a file or takes no file, or that another process is writing (its lock held:
    :func:`~modquad_gym.core.outputs.claim_output_dir`; a hold this process has is granted
    again). ``names`` go into the folder's manifest at once, so that a later ``force`` removes
    them. Yields the folder (None for None: nothing held)."""
    if out_dir is None:
        yield None
        return
    with claim_output_dir(out_dir, names, check_flag(force, "force"), what) as claim:
        for name in names:
            claim.path(name)
        yield claim.folder


@dataclass
class ReportPage:
    """The parts of one validation's ``report.md``: the folder it goes to and whether a page
    there may be replaced (``force``), the validation's page (``compose``:
    :func:`.report_markdown.markdown` given all but ``task_line``), the headline that replaces
    its task line (None: its own) and the sections that follow it, in order. Filled by
    ``validate(page=...)`` (:meth:`begin`) and by the flights after it."""

    folder: Path | None = None
    force: bool = False
    compose: Callable[..., str] | None = None
    task_line: str | None = None
    sections: list[str] = field(default_factory=list)

    @staticmethod
    def checked(page: object, out_dir: object) -> ReportPage | None:
        """``page`` as a door takes it: None, or a ReportPage with an ``out_dir`` to write it
        into that no validation has begun (a ValueError naming ``page`` otherwise, before any
        simulation)."""
        if page is None:
            return None
        if not isinstance(page, ReportPage):
            raise ValueError(f"page must be a ReportPage or None, got {type(page).__name__}")
        if out_dir is None:
            raise ValueError("page: given without out_dir, where report.md would be written")
        page._refuse_begun()
        return page

    def _refuse_begun(self) -> None:
        """A page is one validation's: one that a validation began (its sections and headline
        in it) is refused, not carried into the next's ``report.md``."""
        if self.compose is not None:
            raise ValueError(f"page: already holds the validation into {self.folder}; "
                             "give each validation a new ReportPage")  # fmt: skip

    def begin(self, folder: Path, force: bool, compose: Callable[..., str]) -> ReportPage:
        """The page of the validation just flown into ``folder`` (``compose``: its markdown,
        which takes the keyword ``task_line``); returns ``self``. A ValueError naming ``page``
        for a page begun before."""
        self._refuse_begun()
        self.folder, self.force, self.compose = Path(folder), force, compose
        return self

    def text(self) -> str:
        """``report.md``: the validation's page with :attr:`task_line`, then each section
        after a blank line."""
        if self.compose is None:
            raise ValueError("page: no validation has composed it (validate(page=...) first)")
        return self.compose(task_line=self.task_line) + "".join("\n" + s for s in self.sections)

    def write(self, record: dict, what: str = "out_dir") -> None:
        """Write ``report.md`` (:meth:`text`) and ``validation.json`` (``record``) into the
        folder, each once, under a hold of it (granted again within the validation's own
        :func:`hold_out_dir`; alone, an existing page or record there is refused unless
        ``force``, ``what`` naming the folder). The hold records and removes nothing: the
        validation's own hold put both names in the folder's manifest."""
        page = self.text()
        with hold_output_dir(self.folder, REPORT_FILES, self.force, what) as d:
            write_text(d / REPORT_FILES[0], page)
            write_text(d / REPORT_FILES[1], json.dumps(record, indent=2) + "\n")
