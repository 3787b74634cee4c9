"""The API page lists every public name, and the docs call only names that exist and are on it."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import modquad_gym as mq

ROOT = Path(__file__).resolve().parents[1]
API = (ROOT / "docs" / "api.md").read_text()
ENTRIES = set(re.findall(r"^::: ([\w.]+)", API, re.M))
PAGES = [p for p in sorted((ROOT / "docs").rglob("*.md")) if p.name != "changelog.md"]
PAGES.append(ROOT / "README.md")
DOTTED = re.compile(r"\bmodquad_gym(?:\.[A-Za-z_]\w*)+")
FROM_IMPORT = re.compile(r"^from (modquad_gym[\w.]*) import \(?([\w ,\n]+?)\)?$", re.M)


def resolve(path: str) -> object:
    """The object a dotted path names (a module, or an attribute of one); AttributeError or
    ImportError where the package has none."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for part in parts[cut:]:
            obj = getattr(obj, part)
        return obj
    raise ImportError(path)


def documented() -> dict[str, object]:
    """Every object the API page renders: each ``::: path`` and each name of its ``members:``."""
    found = {}
    for block in re.split(r"^(?=::: )", API, flags=re.M)[1:]:
        path = block.split()[1]
        found[path] = resolve(path)
        members = re.search(r"members: \[([^\]]*)\]", block)
        for name in members.group(1).replace("\n", " ").split(",") if members else ():
            found[f"{path}.{name.strip()}"] = resolve(f"{path}.{name.strip()}")
    return found


def names_the_docs_call() -> dict[str, str]:
    """Dotted ``modquad_gym.x.NAME`` in a page, and ``from modquad_gym.x import NAME`` in its
    code, by name with the page that says it; modules and private names left out (a page cites
    code it does not ask users to call by file path, ``oracle/walk.py``)."""
    found = {}
    for page in PAGES:
        text = page.read_text()
        for path in DOTTED.findall(text):
            found.setdefault(path, page.name)
        for module, names in FROM_IMPORT.findall(text):
            for name in names.replace("\n", " ").split(","):
                found.setdefault(f"{module}.{name.split(' as ')[0].strip()}", page.name)
    return {
        path: page
        for path, page in found.items()
        if not path.rsplit(".", 1)[-1].startswith("_") and path != "modquad_gym"
    }


def test_every_name_of_the_package_is_on_the_api_page():
    missing = [name for name in mq.__all__ if f"modquad_gym.{name}" not in ENTRIES]
    assert not missing, f"docs/api.md lacks ::: modquad_gym.NAME for {missing}"


def on_api_page(path: str, page: dict[str, object]) -> bool:
    """``path`` is on the page under its own path or as the same object under another one
    (``modquad_gym.solvers.make_solver`` is ``modquad_gym.make_solver``; a number or a string
    only under its own path)."""
    obj = resolve(path)
    same = [o for o in page.values() if o is obj and (callable(o) or isinstance(o, dict))]
    return path in page or bool(same)


def test_every_name_the_docs_call_exists_and_is_on_the_api_page():
    page = documented()
    called = names_the_docs_call()
    assert "modquad_gym.sim.export.thrust_to_weight" in called  # the scan reads prose and code
    assert "modquad_gym.oracle.margin_with" in called
    unknown, missing = [], []
    for path, where in sorted(called.items()):
        try:
            obj = resolve(path)
        except (AttributeError, ImportError):
            unknown.append(f"{path} ({where})")
            continue
        if type(obj).__name__ != "module" and not on_api_page(path, page):
            missing.append(f"{path} ({where})")
    assert not unknown, f"the docs call names the package lacks: {unknown}"
    assert not missing, f"docs/api.md lacks names the docs call: {missing}"


def test_the_names_the_pages_call_bare_in_prose_are_on_the_api_page():
    """``hover_f_max(structure)`` (export.md), ``bound_levels(problem)`` (search.md),
    ``write(result, problem, path)`` (certificates.md): the scan above does not see them."""
    page = documented()
    for path in ("modquad_gym.sim.export.hover_f_max", "modquad_gym.search.bound_levels",
                 "modquad_gym.search.certificates.write"):  # fmt: skip
        assert on_api_page(path, page), path


def test_the_docs_call_only_names_the_package_has():
    """``mq.NAME`` in a page or the README names a public name or a subpackage (``mq.beam_search``
    was used before it was one)."""
    for page in PAGES:
        for name in set(re.findall(r"\bmq\.([A-Za-z_]\w*)", page.read_text())):
            assert name in mq.__all__ or name == "__version__" or hasattr(mq, name), (page, name)
