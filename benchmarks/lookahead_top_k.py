"""The exact lookahead's shortlist (the env's ``lookahead_top_k``): how often the shipped policy's
choice and greedy's lie among the k best children by support bounds, and what the single pass
then uses and costs beside greedy.

    python -m benchmarks.lookahead_top_k [--bands 16 32 64] [--families planted mixed payload
        torque] [--per-family 2] [--k 4 8 16]
        [--small 24] [--time-limit 60] [--out results/lookahead_top_k] [--force]

Tasks (never the held-out suites): the scale families' validation draws
(:func:`modquad_gym.scoring.scale_tasks.draw` with ``validation=True``, where settings are tuned)
in each band, searched with n_max ``max(64, band)``, and ``--small`` tasks of the ``mixed``
generator at n_max 7 drawn from ``default_rng([SEED, i])``. Per task, in one process after an
untimed warm-up: the shipped model's single pass with every child decided exactly (``top_k``
None, the shipped behaviour before the shortlist), recording at each state the rank of its choice
and of greedy's among the valid actions ordered by support bounds
(:func:`modquad_gym.envs.assembly.lookahead.ranked`); then the single pass with each k; then
greedy. Modules and CPU seconds per pass (each structure verified by the exact LP).
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.common import (
    Distinct,
    bench_args,
    command_as_run,
    made_by,
    markdown_table,
    run_main,
    write_csv,
)
from modquad_gym.cli.common import time_limit_option
from modquad_gym.core.options import int_option
from modquad_gym.core.outputs import write_text

OUTPUTS = ("report.md", "rows.csv", "ranks.csv")
FAMILIES = ("planted", "mixed", "payload", "torque")


def tasks_of(bands, families, per_family: int, small: int, seed: int) -> list[tuple]:
    """(task, n_max, palette for the learned pass, palette for greedy, family, band). A small
    task is named ``small-SEED-I-GENERATOR`` after its draw, so that rows pair task by task
    (the generator's own name repeats: it names only which of two generators drew it)."""
    from modquad_gym.geometry.module import TModule
    from modquad_gym.scoring.scale_tasks import draw, task_palette
    from modquad_gym.scoring.suites import relabelled
    from modquad_gym.tasks import make_generator

    out = []
    mixed = make_generator("mixed")
    for i in range(small):
        task = mixed(np.random.default_rng([seed, i]))
        task = relabelled(task, f"small-{seed}-{i}-{task.name}", task.meta)
        out.append((task, 7, None, None, "small", 7))
    for band in bands:
        for family in families:
            for i in range(per_family):
                task = draw(family, band, i, validation=True)
                palette = task_palette(task)
                learned = palette if palette or task.kind == "total" else [TModule()]
                out.append((task, max(64, band), learned, palette, family, band))
    return out


def ranks_of_pass(solver, task) -> list[tuple[int, int, int]]:
    """(rank of the policy's choice, rank of greedy's, valid actions) at each state of the
    policy's single pass (every start type) with every child decided exactly."""
    from modquad_gym.envs.assembly.lookahead import flagged, ranked

    policy = solver.policy
    env = policy.env
    out = []
    for start in policy.starts:
        obs, info = policy.reset(task, start)
        done = info["success"]
        while not done:
            mask = env.action_masks()
            action = policy.greedy(obs, mask)
            state = env.state
            order = ranked(env.unwrapped._episode, state, np.flatnonzero(state.mask)).tolist()
            greedys = flagged(obs["candidates"], mask)
            out.append((order.index(action), order.index(greedys), len(order)))
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
    return out


def timed(solver, task) -> tuple[int | None, float]:
    from modquad_gym.search import verified

    cpu = time.process_time()
    r = solver.solve(task)
    seconds = time.process_time() - cpu
    return (r.n_modules if verified(r.structure, task) else None), seconds


def measure(args) -> tuple[list[dict], list[dict]]:
    from modquad_gym.solvers import make_solver

    rows, ranks = [], []
    solvers: dict = {}

    def solver(method: str, n_max: int, palette, top_k="-"):
        key = (method, n_max, tuple(m.name for m in palette or ()), top_k)
        if key not in solvers:
            extra = {} if top_k == "-" else {"top_k": top_k, "extra_fallbacks": ()}  # one pass
            solvers[key] = make_solver(method, n_max=n_max, modules=palette,
                                       time_limit=args.time_limit, **extra)  # fmt: skip
        return solvers[key]

    tasks = tasks_of(args.bands, args.families, args.per_family, args.small, args.seed)
    warmed = set()
    for task, n_max, learned, palette, family, band in tasks:
        variants = [("ppo", learned, None), *[("ppo", learned, k) for k in args.k]]
        variants.append(("greedy", palette, "-"))
        if (n_max, family) not in warmed:  # imports, compilation, caches: untimed
            warmed.add((n_max, family))
            for method, pal, top_k in variants:
                solver(method, n_max, pal, top_k).solve(task)
            solvers.clear()
        row = {"family": family, "band": band, "task": task.name}
        for method, pal, top_k in variants:
            name = method if top_k == "-" else f"ppo-top{top_k or 'all'}"
            found, seconds = timed(solver(method, n_max, pal, top_k), task)
            row[f"{name}_modules"], row[f"{name}_s"] = found, round(seconds, 3)
        for pick, flag, valid in ranks_of_pass(solver("ppo", n_max, learned, None), task):
            ranks.append({"family": family, "band": band, "task": task.name,
                          "policy_rank": pick, "greedy_rank": flag, "valid": valid})  # fmt: skip
        rows.append(row)
        print(row, flush=True)
    return rows, ranks


def summary(rows: list[dict], ranks: list[dict], ks) -> tuple[list[dict], list[dict]]:
    """Per (family, band): recall of the policy's and greedy's choice within each k; and per
    (family, band, variant): solved, mean modules above greedy's on the tasks both solve, CPU
    seconds over greedy's."""
    recall, passes = [], []
    groups = sorted({(r["band"], r["family"]) for r in rows})
    names = ["ppo-topall", *[f"ppo-top{k}" for k in ks]]
    for band, family in groups:
        rk = [r for r in ranks if (r["band"], r["family"]) == (band, family)]
        valid = round(float(np.mean([r["valid"] for r in rk])), 1) if rk else None
        rec = {"band": band, "family": family, "states": len(rk), "mean_valid": valid}
        for k in ks:
            rec[f"policy_in_top{k}"] = round(np.mean([r["policy_rank"] < k for r in rk]), 3)
            rec[f"greedy_in_top{k}"] = round(np.mean([r["greedy_rank"] < k for r in rk]), 3)
        recall.append(rec)
        mine = [r for r in rows if (r["band"], r["family"]) == (band, family)]
        g_s = sum(r["greedy_s"] for r in mine)
        for name in names:
            both = [r for r in mine if r[f"{name}_modules"] and r["greedy_modules"]]
            diff = [r[f"{name}_modules"] - r["greedy_modules"] for r in both]
            passes.append({
                "band": band, "family": family, "method": name, "tasks": len(mine),
                "solved": sum(bool(r[f"{name}_modules"]) for r in mine),
                "greedy_solved": sum(bool(r["greedy_modules"]) for r in mine),
                "modules_minus_greedy": round(float(np.mean(diff)), 2) if diff else None,
                "seconds_over_greedy": round(sum(r[f"{name}_s"] for r in mine) / g_s, 3),
            })  # fmt: skip
    return recall, passes


def parse_args(argv: list[str] | None):
    """The options, each checked while the command line is read (one line, exit 2), and a plan
    with tasks to run, before any model load or search."""
    args = bench_args(
        argv,
        "python -m benchmarks.lookahead_top_k",
        __doc__.split("\n\n")[0],
        {
            "--bands": {"type": int_option(2, 128), "nargs": "*", "action": Distinct,
                        "default": [16, 32, 64], "help": "size bands (none: only --small)"},
            "--families": {"nargs": "+", "action": Distinct, "choices": FAMILIES,
                           "default": list(FAMILIES), "help": "scale families"},
            "--per-family": {"type": int_option(0, 100), "default": 2,
                             "help": "validation draws per family and band"},
            "--k": {"type": int_option(1), "nargs": "+", "action": Distinct,
                    "default": [4, 8, 16], "help": "shortlists"},
            "--small": {"type": int_option(0, 10_000), "default": 24,
                        "help": "mixed tasks at n_max 7"},
            "--time-limit": {"type": time_limit_option, "default": 60.0,
                             "help": "seconds each method gets per task, in (0, 86400]"},
        },
        out="results/lookahead_top_k",
        outputs=OUTPUTS,
    )  # fmt: skip
    if not (args.bands and args.per_family) and not args.small:
        raise ValueError("nothing to run: give --bands with --per-family > 0, or --small > 0")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rows, ranks = measure(args)
    recall, passes = summary(rows, ranks, args.k)
    command = command_as_run("lookahead_top_k", argv)
    text = "\n".join([
        "# The exact lookahead's shortlist (lookahead_top_k)", "",
        made_by(command, "; one process"), "", __doc__.split("\n\n", 2)[2].strip(), "",
        "## Recall: the share of states whose choice lies in the top k by support bounds", "",
        markdown_table(recall), "",
        "## Single pass beside greedy (modules on the tasks both solve; CPU seconds summed)", "",
        markdown_table(passes), "", "## Every task", "", markdown_table(rows), "",
    ])  # fmt: skip
    write_csv(rows, args.out / "rows.csv")
    write_csv(ranks, args.out / "ranks.csv")
    write_text(args.out / "report.md", text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(run_main(main, "lookahead_top_k"))
