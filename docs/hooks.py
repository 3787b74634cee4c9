"""MkDocs hooks (mkdocs.yml ``hooks:``): pages generated from the code, and every page in the nav.

* ``environments/<id>.md``: one page per registered environment (:data:`modquad_gym.envs.ENV_IDS`):
  its registration, its action and observation spaces as built by ``gym.make``, and its class
  docstring (description, spaces, rewards, episode end, arguments, version history).
* ``<!-- modquad-methods -->`` in a page becomes the table of registered methods, their options
  and capabilities (:func:`modquad_gym.methods.table`).
* ``<!-- modquad-cli -->`` in a page becomes the ``--help`` text of every ``modquad`` command and
  action, from the argparse parsers themselves, and of every ``python -m benchmarks.NAME``
  script of the repository.
* The pictures of ``results/`` (and its report folders) are copied into the site under
  ``results/``.
* A Markdown page under docs/ that the nav does not list is added under "Topics", so a plain
  ``docs/<topic>.md`` is always reachable.
"""

from __future__ import annotations

import argparse
import inspect
import os
import re
from pathlib import Path

from mkdocs.structure.files import File

CLI_MARKER = "<!-- modquad-cli -->"
METHODS_MARKER = "<!-- modquad-methods -->"
ENV_FOLDER = "environments"
ENV_SECTION = "Environments"
TOPICS = "Topics"
RESULTS = "results"


# --- nav ------------------------------------------------------------------------------------
def _listed(nav) -> set[str]:
    """Every page path the nav names."""
    out: set[str] = set()
    for item in nav or []:
        value = next(iter(item.values())) if isinstance(item, dict) else item
        if isinstance(value, list):
            out |= _listed(value)
        elif isinstance(value, str):
            out.add(value)
    return out


def on_config(config):
    from modquad_gym.envs import ENV_IDS

    nav = config["nav"]
    section = next(  # the Environments section's list of pages
        (item[ENV_SECTION] for item in nav if isinstance(item, dict) and ENV_SECTION in item), None
    )
    listed = _listed(nav)
    if section is not None:
        section += [
            {env_id: f"{ENV_FOLDER}/{env_id}.md"}
            for env_id in ENV_IDS
            if f"{ENV_FOLDER}/{env_id}.md" not in listed
        ]
    docs = Path(config["docs_dir"])
    missing = sorted(
        p.relative_to(docs).as_posix()
        for p in docs.rglob("*.md")
        if p.relative_to(docs).as_posix() not in listed | _listed(nav)
    )
    if missing:
        nav.append({TOPICS: missing})
    return config


# --- environment pages ----------------------------------------------------------------------
def on_files(files, config):
    from modquad_gym.envs import ENV_IDS

    root = Path(config["config_file_path"]).parent
    for png in sorted((root / RESULTS).rglob("*.png")):  # the reports' pictures, as results/...
        files.append(File(png.relative_to(root).as_posix(), str(root), config["site_dir"],
                          config["use_directory_urls"]))  # fmt: skip
    for env_id in ENV_IDS:
        files.append(
            File.generated(config, f"{ENV_FOLDER}/{env_id}.md", content=environment_page(env_id))
        )
    return files


def environment_page(env_id: str) -> str:
    """The Markdown page of one registered environment."""
    import gymnasium as gym

    import modquad_gym  # noqa: F401 - registers the ids

    spec = gym.spec(env_id)
    env = gym.make(env_id)
    try:
        base = env.unwrapped
        cls = type(base)
        rows = [
            ("make", f'`gym.make("{env_id}")`'),
            ("class", f"`{cls.__module__}.{cls.__qualname__}`"),
            ("registered keywords", f"`{spec.kwargs}`" if spec.kwargs else "none"),
            (
                "max_steps",
                f"`{base.max_steps}` (the env's own step limit, 4 * n_max: it follows `n_max`; "
                "registered without a `TimeLimit`: `env.spec.max_episode_steps` is None)",
            ),
            (
                "reward_threshold",
                f"`{env.spec.reward_threshold}` (the return every successful "
                "episode without invalid actions reaches; see Rewards)",
            ),
            ("action space", f"`{env.action_space}`"),
            ("render modes", ", ".join(f"`{m}`" for m in base.metadata["render_modes"])),
        ]
        obs = [
            f"| `{key}` | `{space.shape}` | `{space.dtype}` | {_bounds(space)} |"
            for key, space in env.observation_space.spaces.items()
        ]
    finally:
        env.close()
    parts = [inspect.getdoc(cls) or ""]
    module_set = getattr(base, "module_set", None)
    if module_set is not None and getattr(base, "n_types", 1) > 1:  # a palette: its rules
        parts.append("## Module types\n\n" + inspect.getdoc(inspect.getmodule(type(module_set))))
    doc = markdown_docstring("\n\n".join(parts))
    history = version_history(Path(__file__).resolve().parents[1] / "CHANGELOG.md", env_id)
    lines = [
        f"# {env_id}",
        "",
        "Generated from the registration and the class docstring by `docs/hooks.py`.",
        "",
        "| | |",
        "|---|---|",
        *(f"| {k} | {v} |" for k, v in rows),
        "",
        "## Observation space (default keywords)",
        "",
        "| key | shape | dtype | bounds |",
        "|---|---|---|---|",
        *obs,
        "",
        "## Documentation",
        "",
        doc,
        "",
        "## Version history",
        "",
        history,
    ]
    return "\n".join(lines) + "\n"


def version_history(changelog: Path, env_id: str) -> str:
    """The environments' version history: the CHANGELOG.md section titled "... -v0 history"
    (every registered id shares the version of the one environment class)."""
    version = env_id.rsplit("-", 1)[1]
    match = re.search(rf"^## .*-{version} history.*?\n(.*?)(?=^## |\Z)", changelog.read_text(),
                      flags=re.M | re.S)  # fmt: skip
    if match is None:
        raise ValueError(f"{changelog}: no section '## ...-{version} history' for {env_id}")
    return match.group(1).strip()


def _bounds(space) -> str:
    if not hasattr(space, "low"):
        return str(space)
    return f"[{float(space.low.min()):g}, {float(space.high.max()):g}]"


_ROLE = re.compile(r":(?:class|func|meth|mod|attr|data|obj|exc):`~?([^`]+)`")


def markdown_docstring(text: str) -> str:
    """A docstring as Markdown: reST roles become code, ``## X`` sections move one level down."""
    text = _ROLE.sub(lambda m: f"`{m.group(1).split('.')[-1]}`", text)
    return re.sub(r"^## ", "### ", text, flags=re.M)


# --- command line ---------------------------------------------------------------------------
def on_page_markdown(markdown, page, config, files):
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_reference())
    if METHODS_MARKER in markdown:
        from modquad_gym.methods import table

        markdown = markdown.replace(METHODS_MARKER, table())
    return markdown


def cli_reference() -> str:
    """``modquad --help`` and the help of every command, action and benchmark, as Markdown."""
    from modquad_gym.cli import build_parser

    os.environ["COLUMNS"] = "100"  # argparse wraps at the terminal width: fix it
    out: list[str] = []

    def walk(parser: argparse.ArgumentParser, depth: int) -> None:
        out.extend([f"{'#' * depth} `{parser.prog}`", "", "```text", parser.format_help().rstrip(),
                    "```", ""])  # fmt: skip
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub in dict.fromkeys(action.choices.values()):  # aliases once
                    walk(sub, min(depth + 1, 4))

    walk(build_parser(), 2)
    out += ["## Benchmarks", "",
            "The project's measurement scripts are not installed with the package: from the "
            "repository's root, `python -m benchmarks.NAME` runs one (each writes its report "
            "under `results/`; see [Results](results.md)).", ""]  # fmt: skip
    for name in _benchmarks():
        out.extend([f"### `python -m benchmarks.{name}`", "", "```text", bench_help(name), "```",
                    ""])  # fmt: skip
    return "\n".join(out)


def _root_on_path() -> None:
    """The repository's root on the path, for ``benchmarks``."""
    import sys

    root = str(Path(__file__).resolve().parents[1])
    if root not in sys.path:
        sys.path.insert(0, root)


def _benchmarks() -> dict[str, str]:
    """:func:`benchmarks.common.scripts` (the repository's root put on the path)."""
    _root_on_path()
    from benchmarks.common import scripts

    return scripts()


def bench_help(name: str) -> str:
    """``python -m benchmarks.NAME --help``: each script parses its own options in
    ``main(argv)``."""
    import contextlib
    import importlib
    import io

    _root_on_path()  # not scripts(): it parses every benchmark's source, ~0.4 s a call
    text = io.StringIO()
    with contextlib.redirect_stdout(text), contextlib.suppress(SystemExit):
        importlib.import_module(f"benchmarks.{name}").main(["--help"])
    return text.getvalue().rstrip()
