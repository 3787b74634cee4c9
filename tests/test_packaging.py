"""What travels: the sdist holds the whole project (its tests pass from it), the wheel holds one
top-level package with its example tasks, and the hygiene files agree with the one version."""

from __future__ import annotations

import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

import modquad_gym
from modquad_gym.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def dists(tmp_path_factory) -> tuple[Path, Path]:
    """The sdist and the wheel built from it (``python -m build``: sdist first, then the wheel
    from the unpacked sdist, so a file missing from the sdist breaks the wheel too)."""
    out = tmp_path_factory.mktemp("dist")
    subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out),
                    str(ROOT)], check=True, capture_output=True, timeout=600)  # fmt: skip
    (sdist,) = out.glob("modquad_gym-*.tar.gz")
    (wheel,) = out.glob("modquad_gym-*.whl")
    return sdist, wheel


def test_sdist_holds_the_whole_project(dists):
    sdist, _ = dists
    with tarfile.open(sdist) as tar:
        members = {m.name.split("/", 1)[1]: m for m in tar.getmembers() if "/" in m.name}
    for name in ("train.py", "requirements.txt", "LICENSE", "CITATION.cff", "README.md",
                 "pyproject.toml", "MANIFEST.in", "examples/screwdriver.json",
                 "examples/byo_agent.py", "examples/rl_zoo/ppo.yml", "agents/training.py",
                 "benchmarks/common.py", "benchmarks/oracle.py", "benchmarks/reference_search.py",
                 "tests/conftest.py", "tests/test_packaging.py", ".ci/run",
                 "modquad_gym/data/examples/screwdriver.json"):  # fmt: skip
        assert name in members, f"sdist lacks {name}"
        assert not members[name].issym(), f"{name} is a link in the sdist"
    for path in ROOT.glob("docs/**/*.md"):
        assert path.relative_to(ROOT).as_posix() in members
    assert not any("__pycache__" in name for name in members)


def test_wheel_has_one_package_with_its_examples_and_type_marker(dists):
    _, wheel = dists
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        meta = z.read(f"modquad_gym-{modquad_gym.__version__}.dist-info/METADATA").decode()
    assert {n.split("/")[0] for n in names} == {
        "modquad_gym",
        f"modquad_gym-{modquad_gym.__version__}.dist-info",
    }  # no benchmarks/, tests/ or agents/: the laboratory stays in the repository
    assert "modquad_gym/scoring/agents.py" in names
    assert not any(n.startswith("modquad_gym/bench/") for n in names)
    assert not any("ppo_large" in n for n in names)  # no product path loads it
    for name in ("modquad_gym/py.typed", "modquad_gym/data/examples/screwdriver.json",
                 "modquad_gym/data/examples/paper_seed0.csv", "modquad_gym/data/rl_zoo/ppo.yml",
                 f"modquad_gym-{modquad_gym.__version__}.dist-info/licenses/LICENSE"):  # fmt: skip
        assert name in names
    assert f"Version: {modquad_gym.__version__}\n" in meta
    assert "License-Expression: MIT\n" in meta


def test_the_package_imports_nothing_of_the_repository_outside_it():
    """The wheel holds only ``modquad_gym``: a module of it that imports the repository's
    ``tests``, ``benchmarks``, ``agents``, ``examples`` or ``train`` (even lazily, inside a
    function) works in a clone and fails installed. The wheel check found one: ``modquad bench
    oracle`` and the docs build stopped at ``No module named 'tests'`` from the wheel."""
    import ast

    outside = {"tests", "benchmarks", "agents", "examples", "docs", "train"}
    found = []
    for path in sorted((ROOT / "modquad_gym").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            found += [f"{path.relative_to(ROOT)}:{node.lineno} {name}" for name in names
                      if name.split(".")[0] in outside]  # fmt: skip
    assert not found, found


def test_citation_names_the_paper_and_this_version():
    yaml = pytest.importorskip("yaml")
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert cff["version"] == modquad_gym.__version__
    assert cff["preferred-citation"]["title"] == "Finding Optimal Modular Robots for Aerial Tasks"
    assert "MIT License" in (ROOT / "LICENSE").read_text()


def test_examples_are_reachable_by_name(tmp_path, capsys):
    from modquad_gym.tasks import TaskRequirement, example_names, example_path

    assert {"screwdriver", "paper_seed0", "planted_seed1", "paper_seed0.csv"} <= set(
        example_names()
    )
    task = TaskRequirement.load("example:screwdriver")
    assert task.name == "screwdriver" and task.n_wrenches == 2
    # the repository's examples/ links to the shipped files (copies of them in the sdist)
    shipped = example_path("screwdriver").read_bytes()
    assert (ROOT / "examples" / "screwdriver.json").read_bytes() == shipped
    out = tmp_path / "s.json"
    assert main(["task", "example", "screwdriver", "--out", str(out)]) == 0
    assert TaskRequirement.load(out).n_wrenches == 2
    assert main(["task", "example", "screwdriver", "--out", str(out)]) == 2  # no --force
    assert main(["task", "example"]) == 0
    assert "planted_seed1" in capsys.readouterr().out
    assert main(["solve", "--task", "example:paper_seed0.csv", "--json"]) == 0
    assert '"n_modules": 5' in capsys.readouterr().out


def test_unknown_example_is_one_line_naming_the_known(capsys):
    assert main(["solve", "--task", "example:nope"]) == 2
    err = capsys.readouterr().err
    assert "unknown example 'nope'" in err and "screwdriver" in err and err.count("\n") == 1
    assert main(["task", "example", "../pyproject"]) == 2


def test_rl_zoo_config_is_package_data_naming_the_wrapper():
    """The RL Zoo hyperparameter file the docs' command reads is installed with the package
    (package-data names it; the wheel test above finds it in the wheel) and configures an id
    and a wrapper that exist; the repository's examples/ links to it."""
    yaml = pytest.importorskip("yaml")
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    from modquad_gym.envs.wrappers import RL_ZOO_CONFIG, NearestValidAction

    package = Path(modquad_gym.__file__).parent
    assert RL_ZOO_CONFIG.is_file() and RL_ZOO_CONFIG.is_relative_to(package)
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert any(
        RL_ZOO_CONFIG.relative_to(package).match(g) for g in globs["package-data"]["modquad_gym"]
    )
    config = yaml.load(RL_ZOO_CONFIG.read_text(), Loader=yaml.UnsafeLoader)  # the Zoo's loader
    (env_id,) = config
    assert env_id in __import__("gymnasium").registry
    assert config[env_id]["env_wrapper"] == [
        f"{NearestValidAction.__module__}.{NearestValidAction.__name__}"
    ]
    assert (ROOT / "examples" / "rl_zoo" / "ppo.yml").read_bytes() == RL_ZOO_CONFIG.read_bytes()
