"""What the RL stage of training added to the cloned policy, per run and over seeds.

    python -m benchmarks.rl_stage RUN [RUN ...] [--out results/rl_stage] [--force]

A RUN is a ``train.py`` run folder (``model.zip``, ``config.json``, ``evaluations.npz``) whose
config names its cloned start (``cloned_model``: the policy PPO started from). Per run: the
validation optimal share and success of the cloned start (step 0) and of the kept model (the
run's ``model.zip``: its best validation checkpoint, or the cloned start when that checkpoint is
not significantly better) and its step, the best checkpoint's share, the final evaluation,
whether the curve rose (its last quarter's mean optimal share above step 0's); and, never used
in training or selection, a single deterministic pass of the cloned start, of the kept model
and of the best checkpoint (``best_model.zip`` in the run's log folder, :func:`checkpoints`;
a run whose best checkpoint is not its kept model and cannot be found is refused) on the tier's
held-out suites (optimal share and success against the certified optima). Over
the runs: the mean of each gain over the cloned start (:data:`GAINS`) with its 95 % percentile
bootstrap interval over runs (:func:`modquad_gym.scoring.stats.interval`). The kept and best
checkpoints' validation gains are >= 0 by construction (step 0 is a candidate of the choice);
the last quarter's mean on validation (no choice) and the held-out gain are the unbiased ones.
Writes report.md, report.csv and curves.png (validation optimal share over PPO steps, one
line per run).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    read_input_text,
    report_page,
    run_main,
    write_report,
)
from modquad_gym.core.interrupts import one_line
from modquad_gym.core.options import path_option
from modquad_gym.scoring.fine_tuning import best_index, read_evaluations
from modquad_gym.scoring.stats import interval
from modquad_gym.scoring.tiers import TIERS

OUTPUTS = ("report.md", "report.csv", "curves.png")
RUN_FILES = ("model.zip", "config.json", "evaluations.npz")
RECORDED = ("optimal", "successes")
"""The evaluations a run's ``evaluations.npz`` holds beside ``timesteps``: one row each."""


def heldout(model: Path, tier: str) -> tuple[float, float]:
    """(optimal share, success) of a single deterministic pass of ``model`` on the tier's
    held-out suites, tasks whose certified optimum is within n_max: the policy's own episode,
    without ``ppo``'s extra pass of greedy's choices (what the RL stage changed, alone)."""
    from modquad_gym.policy.ppo import PPOSolver

    t = TIERS[tier]
    solver = PPOSolver(model=model, n_max=t.n_max, extra_fallbacks=())
    optimal = success = n = 0
    for tasks in t.load_suites().values():
        for task in tasks:
            if task.meta.get("optimum") is None:
                continue
            r = solver.solve(task)
            n += 1
            success += r.structure is not None
            optimal += r.n_modules == task.meta["optimum"]
    return optimal / n, success / n


def cloned_beside(run: Path, tensorboard: Path = Path("runs")) -> Path:
    """The cloned start a run saved among its checkpoints, for a config that names neither its
    log folder nor its cloned start (``train.py``'s log folder: ``<parent>-<run>`` under
    ``runs/`` of the working folder)."""
    run = run.resolve()
    name = run.name if run.parent == tensorboard.resolve() else f"{run.parent.name}-{run.name}"
    return tensorboard / name / "train" / "cloned_model.zip"


def checkpoints(run: Path, config: dict) -> tuple[Path, Path]:
    """(cloned start, best checkpoint) of a run, found from what its config.json records: its
    ``log_dir`` (checkpoints, ``best_model.zip``) and ``cloned_model``, both relative to the run
    folder, so from any working folder. A config without ``log_dir`` records its cloned start
    as the path it was given (absolute, or relative to the folder it trained in); its best
    checkpoint lies beside it, or for a run started ``--init-from`` another run's cloned start
    in its own log folder under ``runs/`` (:func:`cloned_beside`)."""
    recorded = config.get("cloned_model")
    if "log_dir" in config:
        if not isinstance(config["log_dir"], str) or not isinstance(recorded, str | None):
            raise ValueError(f"RUN {run}: config.json's log_dir or cloned_model is not a path")
        logs = run / config["log_dir"]
        return (run / recorded if recorded else logs / "cloned_model.zip"), logs / "best_model.zip"
    cloned = Path(recorded or cloned_beside(run))
    started = isinstance(config.get("imitation"), dict) and "init_from" in config["imitation"]
    logs = cloned_beside(run).parent if started else cloned.parent
    return cloned, logs / "best_model.zip"


def read_run(run: Path) -> tuple[dict, dict]:
    """(config, evaluations) of a ``train.py`` run folder, checked before any held-out pass; a
    ValueError naming the run and what it lacks otherwise."""
    missing = [name for name in RUN_FILES if not (run / name).is_file()]
    if missing:
        raise ValueError(f"RUN {run}: not a train.py run folder (no {', '.join(missing)})")
    try:
        config = json.loads(read_input_text(run / "config.json"))
    except (OSError, ValueError) as exc:
        raise ValueError(f"RUN {run}: config.json unreadable ({one_line(exc)})") from None
    if not isinstance(config, dict) or not {"tier", "seed", "kept_model_timesteps"} <= set(config):
        raise ValueError(f"RUN {run}: config.json has no tier, seed or kept_model_timesteps")
    if config["tier"] not in [*TIERS]:  # any JSON value, a list too
        raise ValueError(f"RUN {run}: config.json names tier {config['tier']!r}, not one of ours")
    data = read_evaluations(run / "evaluations.npz")  # its errors name the run's file
    unrecorded = [name for name in RECORDED if name not in data or not data[name].size]
    if unrecorded:
        raise ValueError(f"RUN {run}: evaluations.npz records no {' or '.join(unrecorded)} "
                         "(train.py records both)")  # fmt: skip
    if config["kept_model_timesteps"] not in data["timesteps"].tolist():
        raise ValueError(f"RUN {run}: config.json's kept_model_timesteps is no evaluation's step")
    cloned, best = checkpoints(run, config)
    if not cloned.is_file():
        raise ValueError(f"RUN {run}: its cloned start {cloned} does not exist")
    kept = data["timesteps"].tolist().index(config["kept_model_timesteps"])
    if best_index(data) != kept and not best.is_file():  # never the kept model's scores for it
        raise ValueError(f"RUN {run}: its best checkpoint {best} does not exist (the best "
                         "validation step is not the kept model's)")  # fmt: skip
    return config, data


def run_row(run: Path, config: dict, data: dict) -> tuple[dict, dict]:
    """The report's row of one run (its :func:`read_run` ``config`` and ``data``) and its
    validation curve."""
    steps = data["timesteps"]
    opt = data["optimal"].mean(axis=1)
    suc = data["successes"].mean(axis=1)
    kept = int(np.flatnonzero(steps == config["kept_model_timesteps"])[0])
    tail = opt[-max(1, len(opt) // 4) :].mean()
    cloned, best = checkpoints(run, config)
    h_clone = heldout(cloned, config["tier"])
    h_kept = heldout(run / "model.zip", config["tier"])
    h_best = h_kept if best_index(data) == kept else heldout(best, config["tier"])
    row = {
        "run": str(run),
        "seed": config["seed"],
        "validation tasks": data["optimal"].shape[1],
        "val optimal, cloned": round(opt[0], 4),
        "val optimal, kept": round(opt[kept], 4),
        "kept step": int(steps[kept]),
        "val optimal, best": round(opt[best_index(data)], 4),
        "val optimal, final": round(opt[-1], 4),
        "val optimal, last quarter mean": round(tail, 4),
        "curve rose": bool(tail > opt[0]),
        "val success, cloned": round(suc[0], 4),
        "val success, kept": round(suc[kept], 4),
        "held-out optimal, cloned": round(h_clone[0], 4),
        "held-out optimal, kept": round(h_kept[0], 4),
        "held-out success, cloned": round(h_clone[1], 4),
        "held-out success, kept": round(h_kept[1], 4),
        "held-out optimal, best": round(h_best[0], 4),
        "held-out success, best": round(h_best[1], 4),
        "ppo seconds": config.get("ppo_seconds"),
    }
    return row, {"steps": steps, "optimal": opt, "label": f"{run.name} (seed {config['seed']})"}


GAINS = {
    "val optimal": ("val optimal, kept", "val optimal, cloned"),
    "val optimal, best checkpoint": ("val optimal, best", "val optimal, cloned"),
    "val optimal, last quarter mean": ("val optimal, last quarter mean", "val optimal, cloned"),
    "val success": ("val success, kept", "val success, cloned"),
    "held-out optimal": ("held-out optimal, kept", "held-out optimal, cloned"),
    "held-out success": ("held-out success, kept", "held-out success, cloned"),
    "held-out optimal, best checkpoint": ("held-out optimal, best", "held-out optimal, cloned"),
    "held-out success, best checkpoint": ("held-out success, best", "held-out success, cloned"),
}
"""Each gain over the cloned start: (the run's column, the cloned start's column). The kept and
best checkpoints' validation gains are >= 0 by construction; the last quarter's mean is the
curve's level without picking its luckiest evaluation."""


def gains(rows: list[dict]) -> list[dict]:
    """Mean gain over the cloned start (:data:`GAINS`) over the runs with its 95 % bootstrap
    interval; none from one or two runs (``n/a (1 run)``, ``n/a (2 runs)``): two runs'
    percentile bootstrap is their range, which holds the true mean about half the time
    (``results/interval_coverage.md``). The runs' own gains are printed beside it."""
    out = []
    for what, (column, cloned) in GAINS.items():
        g = np.array([r[column] - r[cloned] for r in rows])
        point, low, high = interval([g], np.mean)
        few = f"n/a ({len(g)} run{'s' * (len(g) > 1)})"
        ci = few if len(g) < 3 else f"[{100 * low:+.2f}, {100 * high:+.2f}]"
        out.append({"gain (over cloned)": what, "runs": len(g), "mean": f"{100 * point:+.2f} pt",
                    "95 % CI": ci,
                    "per run": " ".join(f"{100 * x:+.1f}" for x in g)})  # fmt: skip
    return out


def plot(curves: list[dict], path: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 4))
    ax = fig.add_subplot()
    for c in curves:
        ax.plot(c["steps"], 100 * c["optimal"], marker=".", label=c["label"])
    ax.set_xlabel("PPO steps (0: the cloned policy)")
    ax.set_ylabel("validation optimal share (%)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    FigureCanvasAgg(fig).print_png(str(path))


def main(argv: list[str] | None = None) -> int:
    args = bench_args(
        argv, "python -m benchmarks.rl_stage", __doc__.split("\n\n")[0],
        {"runs": {"nargs": "+", "type": path_option, "action": Distinct, "key": Path.resolve,
                  "metavar": "RUN", "help": "train.py run folders"}},
        seed_help=None, out="results/rl_stage", outputs=OUTPUTS,
    )  # fmt: skip
    read = [read_run(run) for run in args.runs]  # every run checked before any held-out pass
    rows, curves = [], []
    for run, (config, data) in zip(args.runs, read, strict=True):
        row, curve = run_row(run, config, data)
        rows.append(row)
        curves.append(curve)
    args.out.mkdir(parents=True, exist_ok=True)
    plot(curves, args.out / "curves.png")
    command = "python -m benchmarks.rl_stage " + " ".join(str(r) for r in args.runs)
    command += f" --out {args.out}"
    notes = (
        "Per run: validation optimal share of the cloned start (step 0), of the kept model (the "
        "run's model.zip) and of the best checkpoint, and at the end; the held-out suites' "
        "single pass of the cloned start, of the kept model and of the best checkpoint (never "
        "used in training or selection)."
    )
    text = report_page("What the RL stage added", command, notes, rows, "## Gains over runs", "",
                       _table(gains(rows)), "", "![curves](curves.png)", "")  # fmt: skip
    write_report(args.out, "report", rows, text)
    print(text)
    return 0


def _table(rows: list[dict]) -> str:
    from benchmarks.common import markdown_table

    return markdown_table(rows)


if __name__ == "__main__":
    raise SystemExit(run_main(main, "rl_stage"))
