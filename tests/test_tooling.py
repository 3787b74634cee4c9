"""What outside users plug in: Gymnasium/SB3 conventions, rendering, the installed wheel, the
core-only install, and the bring-your-own-agent example."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import modquad_gym  # noqa: F401 - registers the environments

ROOT = Path(__file__).resolve().parents[1]
OPTIONAL = ("torch", "stable_baselines3", "sb3_contrib", "mujoco", "matplotlib", "ray", "cvxpy",
            "pygame", "moviepy", "tensorboard")  # fmt: skip


def test_info_has_is_success_and_spec_bounds_episodes():
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver")
    assert env.spec.max_episode_steps is None and env.unwrapped.max_steps == 4 * 7
    _, info = env.reset(seed=0)
    assert info["is_success"] == info["success"]
    done = False
    while not done:
        valid = np.flatnonzero(env.unwrapped.action_masks())
        _, _, terminated, truncated, info = env.step(int(valid[0]) if len(valid) else 0)
        done = terminated or truncated
        assert info["is_success"] == info["success"]


def test_eval_callback_reports_a_success_rate(tmp_path):
    pytest.importorskip("sb3_contrib")
    import torch
    from sb3_contrib import MaskablePPO
    from sb3_contrib.common.maskable.callbacks import MaskableEvalCallback
    from stable_baselines3.common.monitor import Monitor

    torch.set_num_threads(1)
    env = Monitor(gym.make("ModQuadAssembly-v0", tasks="screwdriver", n_max=3))
    eval_env = Monitor(gym.make("ModQuadAssembly-v0", tasks="screwdriver", n_max=3))
    model = MaskablePPO("MultiInputPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=0)
    callback = MaskableEvalCallback(
        eval_env, n_eval_episodes=2, eval_freq=32, log_path=str(tmp_path), verbose=0
    )
    model.learn(64, callback=callback)
    assert callback.evaluations_successes, "EvalCallback found no is_success in info"
    assert all(len(s) == 2 for s in callback.evaluations_successes)


def test_human_render_opens_a_window(monkeypatch):
    pytest.importorskip("pygame")
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver", render_mode="human")
    env.reset(seed=0)
    assert env.render() is None
    assert env.unwrapped.viewer.window is not None
    env.close()
    assert env.unwrapped.viewer.window is None


def test_record_video_writes_a_file(tmp_path):
    pytest.importorskip("moviepy")
    env = gym.make("ModQuadAssembly-v0", tasks="screwdriver", render_mode="rgb_array",
                   render_size=(64, 64))  # fmt: skip
    env = gym.wrappers.RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda e: True)
    env.reset(seed=0)
    done = False
    while not done:
        valid = np.flatnonzero(env.unwrapped.action_masks())
        _, _, terminated, truncated, _ = env.step(int(valid[0]) if len(valid) else 0)
        done = terminated or truncated
    env.close()
    assert list((tmp_path / "videos").glob("*.mp4"))


def _python_S(
    code: str, *paths: Path, cwd: Path = ROOT, **variables: str
) -> subprocess.CompletedProcess:
    """Run ``code`` without site processing (so the editable install of this checkout is not
    on the path) and with ``paths`` first on sys.path; ``variables`` join the environment."""
    prelude = f"import sys; sys.path[:0] = {[str(p) for p in paths]!r}\n"
    env = {**os.environ, "OMP_NUM_THREADS": "1", **variables}
    env.pop("PYTHONPATH", None)
    return subprocess.run([sys.executable, "-S", "-c", prelude + code], capture_output=True,
                          text=True, cwd=cwd, env=env, timeout=300)  # fmt: skip


@pytest.fixture(scope="module")
def installed_wheel(tmp_path_factory) -> Path:
    """The package built as a wheel and installed (no dependencies) into its own folder."""
    tmp = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir",
                    str(tmp / "dist"), str(ROOT)], check=True, capture_output=True,
                   timeout=600)  # fmt: skip
    (wheel,) = (tmp / "dist").glob("modquad_gym-*.whl")
    target = tmp / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-index",
                    "--target", str(target), str(wheel)], check=True, capture_output=True,
                   timeout=300)  # fmt: skip
    return target


def test_installed_wheel_solves_with_the_shipped_ppo_model(installed_wheel, tmp_path):
    task = "example:screwdriver"  # shipped in the wheel: no repository file is read
    code = (
        "import modquad_gym, json\n"
        f"assert modquad_gym.__file__.startswith({str(installed_wheel)!r}), modquad_gym.__file__\n"
        "from modquad_gym.cli import main\n"
        f"raise SystemExit(main(['solve', '--task', {str(task)!r}, '--method', 'ppo', '--json']))"
    )
    # numba's kernels run as Python here: this checks the packaging, and compiling them anew
    # for the wheel's path costs most of a minute (the source tree's tests check them compiled)
    out = _python_S(code, installed_wheel, Path(sysconfig.get_paths()["purelib"]), cwd=tmp_path,
                    NUMBA_DISABLE_JIT="1")  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert '"feasible": true' in out.stdout


def test_core_install_solves_and_names_the_missing_extra(installed_wheel, tmp_path):
    """Without the extras: the searches, and the shipped PPO model through its NumPy actor; a
    model without one needs torch, and the error names the extra."""
    block = (
        "import importlib.abc\n"
        "class Block(importlib.abc.MetaPathFinder):\n"
        "    def find_spec(self, name, path, target=None):\n"
        f"        if name.split('.')[0] in {OPTIONAL!r}:\n"
        "            raise ModuleNotFoundError(f'No module named {name!r}', name=name)\n"
        "sys.meta_path.insert(0, Block())\n"
    )
    task = ROOT / "examples" / "screwdriver.json"
    code = block + (
        "import modquad_gym as mq\n"
        "from modquad_gym.cli import main\n"
        f"assert main(['solve', '--task', {str(task)!r}]) == 0\n"
        f"assert main(['solve', '--task', {str(task)!r}, '--method', 'ppo']) == 0\n"
        "import shutil\n"
        "from modquad_gym.policy.models import DEFAULT_MODEL\n"
        "shutil.copyfile(DEFAULT_MODEL, 'model.zip')  # without its actor beside it\n"
        f"raise SystemExit(main(['solve', '--task', {str(task)!r}, '--method', 'ppo', "
        "'--model', 'model.zip']))"
    )
    # numba's kernels as Python, as above: compiling them for the wheel's path cost 30 s of this
    # test, and numba is no extra (the source tree's tests run them compiled)
    out = _python_S(code, installed_wheel, Path(sysconfig.get_paths()["purelib"]), cwd=tmp_path,
                    NUMBA_DISABLE_JIT="1")  # fmt: skip
    assert out.returncode == 2, out.stderr
    assert out.stdout.count("3 modules (certified minimum)") == 2  # the search, then ppo
    assert "pip install 'modquad_gym[train]'" in out.stderr
    assert "Traceback" not in out.stderr


def test_bring_your_own_agent_example_runs_and_is_scored(tmp_path):
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "examples/byo_agent.py"], cwd=ROOT, env=env,
                         capture_output=True, text=True, timeout=300)  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "own agent:     3 modules" in out.stdout
    from modquad_gym.cli import main

    cwd = os.getcwd()
    try:
        os.chdir(ROOT)
        code = main(["score", "--solver", "examples.byo_agent:LargestSupportAgent",
                     "--methods", "exhaustive", "--limit", "2", "--out", str(tmp_path / "rep"),
                     "--no-progress"])  # fmt: skip
    finally:
        os.chdir(cwd)
    assert code == 0
    rows = (tmp_path / "rep" / "benchmark.csv").read_text().splitlines()
    agent_rows = [r for r in rows if "examples.byo_agent:LargestSupportAgent" in r]
    assert len(agent_rows) == 4  # 2 tasks x 2 suites


def test_readme_python_examples_run(monkeypatch):
    monkeypatch.chdir(ROOT)
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 2
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {})


def test_bench_env_reports_the_default_config_with_resets_and_the_ppo_update(tmp_path):
    from benchmarks import env as bench_env
    from benchmarks.env_measure import LOOKAHEADS

    cores = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    try:
        rows = bench_env.main(
            ["--steps", "20", "--warmup", "5", "--default-steps", "60", "--sizes", "1"]
            + ["--scale", "5", "--scale-steps", "20", "--scale-warmup", "2"]
            + ["--lookahead-steps", "10"]
            + ["--out", str(tmp_path), "--machine-note", "shared"]
        )
    finally:  # the benchmark pins this process to one core
        if cores is not None:
            os.sched_setaffinity(0, cores)
    default = rows[0]
    assert default["config"].startswith("gym.make(") and default["steps_per_s"] > 0
    assert default["us_per_reset"] > 0 and default["steps_per_episode"] >= 1
    assert default["ppo_update_ms"] > 0
    assert default["env_over_update"] == pytest.approx(
        1e3 * 256 / default["steps_per_s"] / default["ppo_update_ms"]
    )
    text = (tmp_path / "env_benchmark.md").read_text()
    assert "resets counted" in text and "(shared)" in text and "env / update" in text
    lookaheads = len(LOOKAHEADS)  # off, support, every child exact, the shortlist
    assert len((tmp_path / "env_benchmark.csv").read_text().splitlines()) == 1 + 3 + lookaheads + 2
    assert "Lookahead rows" in text and "lookahead_top_k" in text
    grid, faces = rows[-2:]
    assert (grid["encoding"], faces["encoding"]) == ("grid", "faces")
    assert (grid["actions"], faces["actions"]) == (9**2, 2 * 5 + 2) and faces["steps_per_s"] > 0
    assert "The encodings at the field's sizes" in text
