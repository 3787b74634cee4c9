"""The agent benchmark: every solver on the held-out suites, against the certified optimum.

``modquad score`` (or ``python -m modquad_gym.scoring.agents``) runs each method on every task of
the held-out suites (``modquad_gym/data/suites/heldout_*.json``, never seen in training; each task
carries its optimum from the exhaustive search) and writes to ``--out`` (default ``results``):

* ``benchmark.md``: the machine, the summary per method (success rate, mean modules, share
  solved with the optimal module count, mean gap to the optimum, configurations evaluated and
  oracle calls per task, wall time), the run record (the seed, the versions, each method's
  setup seconds, the re-verification: :mod:`.provenance`), the goals beside what was reached,
  the figures;
* ``benchmark.csv``: one row per (method, task);
* ``benchmark_bars.png``, ``learning_curve.png`` (from the training run's ``evaluations.npz``,
  when a learned method is scored), ``structures.png`` (the outside agents and learned methods
  vs exhaustive vs centrosymmetric on the same tasks).

``--solver package.module:Name`` scores an outside agent (beside the searches unless
``--methods`` says otherwise): it is told the tier's n_max, name and module types and counted
through the :class:`~modquad_gym.solvers.Evaluator` it is handed (docs/benchmarks.md, "Score
your own agent"). Every reported success is an answer of at most n_max modules of the allowed
types, re-verified here by the exact DAQP LP oracle, and again in a fresh process that never
imports an outside agent (:mod:`.recheck`) before anything is written.
"""

from __future__ import annotations

import argparse
import sys
import time
from functools import lru_cache, partial
from pathlib import Path

from modquad_gym.core.extras import require
from modquad_gym.core.interrupts import run_command
from modquad_gym.core.options import DefaultsHelpFormatter, OneLineParser
from modquad_gym.core.outputs import OutputError, check_output_dir, hold_output_dir, write_csv
from modquad_gym.geometry.module import palette
from modquad_gym.methods import REGISTRY, method_of
from modquad_gym.scoring.agents_figures import plot_bars, plot_learning_curve, plot_structures
from modquad_gym.scoring.agents_report import write_report
from modquad_gym.scoring.options import (
    COMMAND,
    DEFAULT_METHODS,
    DESCRIPTION,
    REPORT_FILES,
    SEARCH_METHODS,
    add_options,
    check_evaluations,
    check_train_dir,
    method_label,
)
from modquad_gym.scoring.provenance import run_record
from modquad_gym.scoring.recheck import recheck, suite_sources
from modquad_gym.scoring.scores import Row, summarise
from modquad_gym.scoring.suites import SUITES_DIR, check_optima
from modquad_gym.scoring.tiers import Tier, get_tier, honours_fault, validation_suite
from modquad_gym.scoring.used_options import check_used_options, takes_seed
from modquad_gym.scoring.verdicts import (  # survives: a public name here too
    answer_cells,
    certified,
    judged,
    plain_answer,
    survives,  # noqa: F401
)
from modquad_gym.search.problem import DEFAULT_MODULE
from modquad_gym.solvers import Solver, load_solver, make_solver
from modquad_gym.solvers.factory import model_named
from modquad_gym.solvers.outside import solver_named
from modquad_gym.tasks import TaskRequirement, load_suite


def run_benchmark(
    suites: dict[str, list[TaskRequirement]],
    methods: list[str],
    n_max: int = 7,
    model: Path | None = None,
    seed: int | None = None,
    progress: bool = True,
    workers: int = 1,
    modules: str | None = None,
    tier: str | None = None,
    fault: str | None = None,
    made: dict[str, Solver] | None = None,
    trust_model: bool = False,
    setup: dict[str, float] | None = None,
) -> list[Row]:
    """Every method on every task; a success is an answer of at most ``n_max`` modules of the
    allowed types that the exact oracle verifies. ``workers`` > 1 spreads chunks of tasks over
    Ray tasks (:mod:`modquad_gym.core.distributed`; same rows, but each solver's seconds are
    then measured beside the others). ``modules`` (stock type names, comma-separated) makes the
    searches search over shapes x type assignments; ``tier`` (its name) and both are told to
    outside agents (``package.module:Name`` methods, :class:`~modquad_gym.solvers.ExternalSolver`,
    which count their configurations through an evaluator). ``fault`` (``"rotor"``,
    ``"module"``): every search is asked for an answer that survives any single failure of that
    kind, and a success is one that does (:func:`~modquad_gym.oracle.faults.tolerates`); a
    method that cannot honour it is a ValueError (:func:`~.tiers.honours_fault`). ``made``:
    solvers already made, by method (the outside agents :func:`chosen_methods` loaded), used
    as they are with one worker (each Ray worker makes its own). ``trust_model``: the learned
    methods may unpickle ``model`` (``--trust-model``). ``setup``: filled with the seconds each
    solver made here took to make (none with several workers). ``seed`` (None: 0) is told to
    the methods that draw at random; as ``modquad score`` does, a ValueError refuses a seed no
    method takes, a ``model`` or ``trust_model`` with no learned method and a ``tier`` that is
    not one (:func:`~.used_options.check_used_options`, in Python's words)."""
    from modquad_gym.core.distributed import map_tasks

    check_used_options(methods, model=model, trust_model=trust_model, seed=seed, tier=tier,
                       agents=made)  # fmt: skip
    seed = 0 if seed is None else seed

    jobs = [(name, task) for name, tasks in suites.items() for task in tasks]
    size = 1 if workers == 1 else 8
    chunks = [jobs[i : i + size] for i in range(0, len(jobs), size)]
    if fault is not None and (refused := [m for m in methods if not honours_fault(m)]):
        raise ValueError(f"fault={fault!r}: {', '.join(refused)} cannot honour it")
    config = (tuple(methods), n_max, model, seed, modules, tier, fault, trust_model)
    if workers == 1:  # in this process: the solvers made here and those given, in order
        made = made or {}
        rest, seconds = _made(tuple(m for m in methods if m not in made), *config[1:])
        setup = {} if setup is None else setup
        setup.update(seconds)
        solve = partial(_rows, {m: made[m] if m in made else rest[m] for m in methods},
                        (n_max, modules, fault))  # fmt: skip
    else:
        solve = partial(_solve_chunk, config)
    parts = map_tasks(solve, chunks, workers=workers, progress=progress, desc="benchmark")
    return [row for part in parts for row in part]


def _solvers(*config) -> dict[str, Solver]:
    return _made(*config)[0]


@lru_cache(maxsize=2)
def _made(
    methods: tuple,
    n_max: int,
    model: Path | None,
    seed: int,
    modules: str | None,
    tier=None,
    fault: str | None = None,
    trust: bool = False,
) -> tuple[dict[str, Solver], dict[str, float]]:
    """The solvers of ``methods`` and the seconds each took to make."""
    types = palette(modules) if modules else None
    solvers, seconds = {}, {}
    options = (("model", model), ("seed", seed), ("tier", tier), ("trust_model", trust or None))
    for m in methods:
        takes = {"tier"} if ":" in m else set(method_of(m)[0].options.names())
        takes = takes | {"seed"} if takes_seed(m) else takes - {"seed"}  # not ppo's one pass
        given = {k: v for k, v in options if k in takes and v is not None}
        t0 = time.perf_counter()
        solvers[m] = make_solver(m, n_max, modules=types, fault=fault, **given)
        seconds[m] = time.perf_counter() - t0
    return solvers, seconds


def load_solvers(methods: list[str], n_max: int, model: Path | None, tier: Tier) -> None:
    """Make every method's solver of ``model`` on ``tier`` now (kept for the work that follows
    in this process): a model that does not load or cannot act there fails before any task,
    named as the command line names it (``--model PATH: ...``)."""
    with model_named("--model"):
        _solvers(tuple(methods), n_max, model, 0, tier.modules, tier.name, tier.fault)


def _solve_chunk(config: tuple, jobs: list) -> list[Row]:
    """Rows of every method on a chunk of (suite, task) (solvers made once per process)."""
    return _rows(_solvers(*config), (config[1], config[4], config[6]), jobs)


def _rows(solvers: dict[str, Solver], config: tuple, jobs: list) -> list[Row]:
    """Rows of every solver on a chunk of (suite, task); ``config``: (n_max, modules, fault).
    Each answer is rebuilt from its integer cells on the tier's own types
    (:func:`~modquad_gym.solvers.answers.rebuilt`) before the budget check, the verification
    against the scorer's task and the count; an answer verified below the suite's certified
    optimum is a ValueError (the verification was subverted or the optimum is wrong)."""
    n_max, modules, fault = config
    types = palette(modules) if modules else [DEFAULT_MODULE]
    rows: list[Row] = []
    for suite, task in jobs:
        optimum = task.meta.get("optimum")
        for method, solver in solvers.items():
            r = solver.solve(task)
            answer = plain_answer(r.structure, types, method, task.name)
            ok = judged(answer, task, n_max, types, fault)
            if ok and certified(task.meta, fault) and answer.n_modules < optimum:
                raise ValueError(
                    f"{method}: task {task.name!r}: an answer of {answer.n_modules} modules "
                    f"verified below the suite's certified optimum {optimum}: the verification "
                    "was subverted or the optimum is wrong"
                )
            rows.append(
                Row(suite, task.name, optimum, method, ok, answer.n_modules if ok else None,
                    int(r.evaluated), int(r.oracle_calls), float(r.seconds),
                    answer_cells(answer, types if modules else None) if ok else None)
            )  # fmt: skip
    return rows


def parse_args(argv: list[str] | None, prog: str = COMMAND) -> argparse.Namespace:
    """The options of ``argv``; an ``--out`` that cannot take the report is argparse's error
    before any work."""
    parser = OneLineParser(
        prog=prog, description=DESCRIPTION, formatter_class=DefaultsHelpFormatter
    )
    add_options(parser)
    args = parser.parse_args(argv)
    try:
        check_output_dir(args.out, REPORT_FILES, args.force)
    except OutputError as exc:
        parser.error(str(exc))
    return args


def chosen_methods(args: argparse.Namespace, tier: Tier) -> list[str]:
    """The methods to score: ``--methods`` (default: the searches and the tier's learned
    methods; with ``--solver``, the searches alone beside the outside agents), the ``--solver``
    agents, and ``--samples`` in place of ``ppo-kN``. Each is checked here, before any work: a
    method name, an outside agent (made once, with the run's seed: kept in ``args.agents`` for
    the scoring, its import and construction timed in ``args.setup``), the model of a learned
    method."""
    types = palette(tier.modules) if tier.modules else None
    told = dict(n_max=args.n_max or tier.n_max, tier=tier.name, modules=types, fault=tier.fault,
                seed=0 if args.seed is None else args.seed)  # fmt: skip
    agents, args.setup = {}, {}  # `--solver pkg` without `:Name`: load_solver says how
    for spec in args.solver:
        with solver_named("--solver"):
            agents[spec] = _timed(args.setup, spec, load_solver, told)
    model = tier.model if args.model is None else args.model
    default = DEFAULT_METHODS if tier.name == "current" else SEARCH_METHODS
    if tier.name != "current" and model.is_file():
        default = (*SEARCH_METHODS, *tier.learned)
    if args.solver:  # the report is about the outside agent: the searches are its reference
        default = SEARCH_METHODS
    if tier.fault:  # only the methods that guarantee survival are scored there
        default = tuple(m for m in default if honours_fault(m))
    given = [method_label(m) if ":" not in m else m for m in args.methods or default]
    methods = list(dict.fromkeys([*given, *args.solver]))  # each once, under one name
    for m in methods:  # a bad name fails now, as itself, not in a worker after the work began
        if ":" not in m:
            method_of(m)
    if tier.fault and (refused := [m for m in methods if not honours_fault(m)]):
        honoured = [m for m in REGISTRY if honours_fault(m)]
        raise ValueError(
            f"--tier {tier.name}: {', '.join(refused)} cannot guarantee an answer that survives "
            f"a {tier.fault} failure; score the methods that take fault= "
            f"({', '.join(honoured)})"
        )
    methods = with_samples(methods, args.samples, "--methods" if args.methods else "")
    for spec in (m for m in methods if ":" in m and m not in agents):  # --methods pkg:Name
        with solver_named("--methods"):
            agents[spec] = _timed(args.setup, spec, load_solver, told)
    check_used_options(methods, model=args.model, trust_model=args.trust_model, seed=args.seed,
                       train_dir=args.train_dir, agents=agents, flags=True)  # fmt: skip
    check_report_inputs(args, methods, model)
    args.model, args.agents = model, agents
    return methods


def _timed(seconds: dict, spec: str, make, told: dict):
    """``make(spec, **told)``, its seconds kept in ``seconds[spec]``."""
    t0 = time.perf_counter()
    out = make(spec, **told)
    seconds[spec] = time.perf_counter() - t0
    return out


def with_samples(methods: list[str], samples: int | None, given: str) -> list[str]:
    """``methods`` with ``--samples N`` in place of their ``ppo-kN`` (0: without them); refused
    when they have none to replace (``given``: the option that named them, "" for the
    default)."""
    if samples is None:
        return methods
    kept = [m for m in methods if not m.startswith("ppo-k")]
    if len(kept) == len(methods):
        where = f"{given} has" if given else "the methods scored by default have"
        hint = f"; add ppo-k{samples} to --methods" if samples else ""
        raise ValueError(f"--samples {samples}: replaces the ppo-kN of --methods, and {where} "
                         f"none{hint}")  # fmt: skip
    return kept + ([f"ppo-k{samples}"] if samples else [])


def check_report_inputs(args: argparse.Namespace, methods: list[str], model: Path) -> None:
    """The ``model`` of a learned method that is not a file, or a ``--train-dir`` that is not a
    training run's folder, is refused before any work (not by a report that leaves its learning
    curve out)."""
    from modquad_gym.policy.models import model_file

    learned = any(m.startswith("ppo") for m in methods)
    if learned:
        model_file(model)
    if args.train_dir is not None:
        check_train_dir(args.train_dir)
    elif learned:  # the report reads the evaluations beside the model
        check_evaluations(model_file(model).parent)


def main(argv: list[str] | None = None, prog: str = COMMAND) -> int:
    """``modquad score`` with the options ``argv`` (default the command line's); usage and
    errors name ``prog``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    return score(parse_args(argv, prog), " ".join([COMMAND, *argv]))


def read_suites(args: argparse.Namespace, tier: Tier) -> dict[str, list]:
    """The suites of ``--suite`` (or the tier's held-out ones), first ``--limit`` tasks of
    each, their optima checked (:func:`~.suites.check_optima`); {} for ``--validation``,
    whose tasks are drawn and certified after every other check."""
    if args.suite:
        where = {Path(path).stem: str(path) for path in args.suite}
        suites = {Path(path).stem: load_suite(path)[: args.limit] for path in args.suite}
    elif args.validation:
        return {}
    else:
        where = {name: str(SUITES_DIR / f"{name}.json") for name in tier.suites}
        suites = tier.load_suites(args.limit)
    types = palette(tier.modules) if tier.modules else None
    for name, tasks in suites.items():
        check_optima(tasks, where[name], types, tier.fault)
    return suites


def score(args: argparse.Namespace, command: str) -> int:
    """Score the methods of ``args`` (:func:`add_options`) and write the report, which records
    ``command`` (the command line that reproduces it). Every option, suite and agent is checked
    before any work."""
    if args.tier is not None and args.suite:
        raise ValueError("give --tier or --suite, not both")
    tier = get_tier(args.tier or "current")
    if args.suite and args.validation:
        raise ValueError("give --validation or --suite, not both")
    if args.validation is not None and args.limit is not None:
        raise ValueError("give --limit or --validation N, not both (N is the number of tasks)")
    suites = read_suites(args, tier)
    n_max = args.n_max if args.n_max is not None else tier.n_max
    methods = chosen_methods(args, tier)
    train_dir = args.train_dir or args.model.parent
    require("matplotlib")  # the report's figures ([viz] extra): said before the work, not after
    with hold_output_dir(args.out, REPORT_FILES, args.force):  # a second run: refused at once
        if args.validation:  # drawn and certified now: the first work
            suites = {"validation": validation_suite(tier, args.validation, not args.no_progress)}
        t0 = time.perf_counter()
        seed = 0 if args.seed is None else args.seed
        has_ppo = any(m.startswith("ppo") for m in methods)
        model = args.model if has_ppo else None  # the tier's, for the report's model line
        with model_named("--model"):  # a model file that is not one, in the flag's words
            rows = run_benchmark(suites, methods, n_max, model, args.seed,
                                 not args.no_progress, args.workers, tier.modules, tier.name,
                                 tier.fault, made=args.agents, trust_model=args.trust_model,
                                 setup=args.setup)  # fmt: skip
        wall = time.perf_counter() - t0
        sources = suite_sources(args.suite, tier, args.validation)
        checked = recheck(rows, len(methods), sources, n_max, tier.modules, tier.fault)
        record = run_record(seed, args.seed is not None, args.setup, methods, checked)
        write_csv([r.as_csv() for r in rows], args.out / "benchmark.csv")
        summary = summarise(rows, methods, n_max)
        evals = train_dir / "evaluations.npz"
        out = args.out
        figures = {
            "summary bars": plot_bars(summary, out / "benchmark_bars.png") if summary else None,
            "learning curve": plot_learning_curve(evals, out / "learning_curve.png")
            if has_ppo
            else None,
            "structures": plot_structures(
                rows,
                out / "structures.png",
                modules=palette(tier.modules) if tier.modules else None,
            ),
        }
        path = write_report(rows, summary, out, suites, args.model, train_dir, n_max,
                            figures, wall, tier.name, command, record)  # fmt: skip
    print(path.read_text())
    return 0


def script(argv: list[str] | None = None) -> int:
    """:func:`main` as ``python -m modquad_gym.scoring.agents`` runs it: a refused input or a
    file that cannot be written is one line and exit 2, as with ``modquad score``."""
    return run_command(main, COMMAND, argv)


if __name__ == "__main__":
    raise SystemExit(script())
