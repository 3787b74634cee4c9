"""``modquad solve``: find a structure for each task file, here or spread over Ray workers."""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from modquad_gym.cli import common, given  # commands call common.load_task (tests replace it)
from modquad_gym.cli.common import (
    add_command,
    add_csv_header,
    add_detection_delay,
    add_fault,
    add_force,
    add_method,
    add_workers,
    batch_status,
    check_fault_method,
    fault_margin_of,
    palette,
    palette_of,
    report_error,
)
from modquad_gym.cli.quiet import add_quiet, shows_progress
from modquad_gym.cli.solve_outputs import (
    check_certificate,
    check_certificate_levels,
    check_export,
    check_outputs_differ,
    export_result,
    write_certificate,
)
from modquad_gym.core.interrupts import one_line
from modquad_gym.methods import OWN_FLAGS, method_of
from modquad_gym.oracle.faults import DELAY_SLOPES
from modquad_gym.policy.models import unused_seed
from modquad_gym.solvers import make_solver
from modquad_gym.solvers.factory import model_named


def add_solve(sub) -> None:
    p = add_command(
        sub,
        "solve",
        cmd_solve,
        help="find a structure for each task file",
        description="Find a structure for each task and print it as a grid "
        "(@ marks the first module), with the module count, configurations "
        "evaluated and seconds. An infeasible task is reported with exit code 0 (2 with "
        "--export, which then has no structure to write).",
    )
    p.add_argument(
        "--task",
        action="append",
        required=True,
        metavar="FILE",
        help="task file (.json, .csv, .npy), a folder of task files, or a quoted glob such as "
        "'tasks/*.json'; repeat for several",
    )
    add_method(p)
    add_fault(p)
    add_detection_delay(
        p,
        "with --fault: design for a controller that learns of the failure this many "
        "seconds late, 0 to 0.05: the required --fault-margin is derived from it by the rule "
        "calibrated on MuJoCo flights (docs/faults.md; margin = "
        f"{DELAY_SLOPES['rotor']:g} x delay for a rotor failure, "
        f"{DELAY_SLOPES['module']:g} x delay for a module, two rotors or a module and a rotor)",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="print one JSON object per task per line: cells, n_modules, lower_bound (proved: "
        "no structure of fewer modules works), evaluated, oracle_calls, feasible, certified "
        "(n_modules == lower_bound), seconds (and modules, the type of each cell, with "
        "--modules; for the default search, history: how the bound and the structure found "
        "improved, a list of {seconds, lower_bound, n_modules, source}); ray_start_seconds, "
        "where one task's search started Ray (--workers): Ray's start, not counted in seconds; "
        "compile_seconds: kernels compiled during the search, once on a cold cache, not counted "
        "in seconds",
    )
    add_quiet(p)
    add_workers(
        p,
        "1, or every CPU of the cluster given by --ray-address / RAY_ADDRESS. Several tasks are "
        "spread over the workers (each search in one process; a task file that cannot be read "
        "is reported and the others go on, exit code 2 at the end); a single task's exhaustive "
        "search splits its levels of more than 262,144 structures (12 modules and up) into "
        "ranges decided on the workers, its default search runs the portfolio's producers "
        "(beam, genetic, greedy, the policy) on N-1 workers beside its own steps (Ray's start, "
        "seconds on a small machine, is not counted in --time-limit nor in the seconds printed, "
        "and Ray stops after the answer is printed); with one task the other methods, and the "
        "exhaustive search over several --modules types or of a task whose rotor wrenches "
        "depend on the structure, run in this process and --workers above 1 (or --ray-address) "
        "is refused. Only the default search's answer may depend on the number of workers (it "
        "depends on timing)",
    )
    add_csv_header(p)
    p.add_argument(
        "--export",
        metavar="FILE",
        default=None,
        help="also write the structure found (one task only) to FILE, in the format of its "
        "suffix: .xml = MJCF, .urdf = URDF, .json = rotor poses, mass, inertia and the "
        "configuration matrix (see `modquad export --help`); where no structure is found (an "
        "infeasible task) it writes nothing, nor the --certificate, and exits 2, as export does",
    )
    p.add_argument(
        "--certificate",
        metavar="FILE",
        default=None,
        help="also write a certificate of the certified answer (one task only) to FILE (.json, "
        "or .json.gz compressed; not the --export file): a proof that `modquad check FILE` "
        "verifies without trusting the search (docs/certificates.md); an answer that is not "
        "certified is refused, as is one whose certificate would prove a level of more than "
        "2,000,000 structures that no level bound covers (at once, before the search, when "
        "every answer's would; else a note names the first such level)",
    )
    add_force(p)


@dataclass(frozen=True)
class SolveSpec:
    """What the command line asks of a solver, parsed once: the method, its options (the
    method's own fields, :mod:`modquad_gym.methods`) and the problem's budget, palette and
    fault. Hashable and picklable: Ray workers make the same solver from it."""

    method: str
    n_max: int
    options: tuple[tuple[str, Any], ...]
    modules: str | None = None
    fault: str | None = None
    fault_margin: float | None = None

    @classmethod
    def of(cls, args: argparse.Namespace, progress: bool = False) -> SolveSpec:
        """The spec of the parsed arguments: ``--time-limit``, ``--seed``, ``--model`` go to the
        method where it takes them (a typed one it does not take was refused before,
        :func:`~modquad_gym.cli.given.refuse_ignored_method_options`), ``--option KEY=VALUE``
        sets any other of its options, each once (one given twice, or beside the flag that
        gives it, is refused); ``progress`` where it shows progress."""
        entry, variant = method_of(args.method)
        takes = entry.options.names()
        options: dict[str, Any] = {}
        for key, value in (("time_limit", getattr(args, "time_limit", None)),
                           ("seed", getattr(args, "seed", None)),
                           ("model", getattr(args, "model", None)),
                           ("trust_model", getattr(args, "trust_model", None) or None),
                           ("progress", progress)):  # fmt: skip
            if key in takes and value is not None:
                options[key] = value
        said: dict[str, str] = {}
        for text in getattr(args, "option", None) or ():
            try:
                key, value = entry.options.parse(args.method, text)
            except TypeError as exc:  # an unknown key: the same words as make_solver's
                raise ValueError(f"--option {text}: {exc}") from None
            if key in said:
                raise ValueError(f"--option {text}: {key} is given twice (--option {said[key]} "
                                 "too); give it once")  # fmt: skip
            if key in OWN_FLAGS and given.typed(args, key):
                raise ValueError(f"--option {text}: {key} is given twice ({OWN_FLAGS[key]} "
                                 f"{getattr(args, key)} too); give it once")  # fmt: skip
            options[key], said[key] = value, text
        given.refuse_conflicting_options(args, entry.options, options, said)
        samples = {**options, **variant}.get("samples", 0)  # ppo's: else it draws nothing
        unused = unused_seed(args.method, options.get("seed", 0), samples)
        if "samples" in takes and unused is not None:
            seed = f"--option {said['seed']}" if "seed" in said else f"--seed {options['seed']}"
            raise ValueError(f"{seed}: {unused}")
        return cls(args.method, args.n_max, tuple(sorted(options.items())),
                   getattr(args, "modules", None), getattr(args, "fault", None),
                   fault_margin_of(args))  # fmt: skip

    def solver(self, engine=None):
        """The solver (:func:`~modquad_gym.solvers.make_solver`); ``engine`` (or None) splits
        the large levels of one search where the method takes one."""
        entry, _ = method_of(self.method)
        options = dict(self.options)
        if engine is not None and "engine" in entry.options.names():
            options["engine"] = engine
        with model_named("--model"):  # the command line's name of a model file that is not one
            return make_solver(self.method, self.n_max, modules=palette_of(self.modules),
                               fault=self.fault, fault_margin=self.fault_margin,
                               **options)  # fmt: skip


@functools.lru_cache(maxsize=4)
def cached_solver(spec: SolveSpec, engine=None):
    """The ``solve`` function of ``spec``'s solver; cached, so a worker process that solves
    many tasks loads a PPO model once."""
    return spec.solver(engine).solve


def solver(args: argparse.Namespace, task=None, engine=None):
    """The ``solve`` function of ``args`` (``engine``'s workers share the levels of one
    search)."""
    return cached_solver(SolveSpec.of(args, shows_progress(args)), engine)


def solve_file(spec: SolveSpec, csv_header: str, path: Path):
    """Load and solve one task file (the unit of work of a batch): (task, result)."""
    task = common.load_task(path, csv_header)
    common.check_task(task, path, palette_of(spec.modules))
    return task, cached_solver(spec)(task)


def cmd_solve(args: argparse.Namespace) -> int:
    from modquad_gym.core.distributed import Engine, Failed
    from modquad_gym.tasks import task_files

    palette(args)  # a bad --modules is refused before any work
    check_fault_method(args)
    spec = SolveSpec.of(args)  # a bad --option too
    paths = task_files(args.task)
    check_outputs_differ(args)
    shares = "engine" in method_of(args.method)[0].options.names()  # its search splits work
    if len(paths) == 1 and not shares:
        dests = ["workers"] if (args.workers or 1) > 1 else []
        given.refuse_ignored(args, [*dests, "ray_address"], f"method {args.method!r} solves one "
                             "task in this process: workers share several --task files, or one "
                             "task's exhaustive or anytime search")  # fmt: skip
    if args.export is not None:
        check_export(args.export, len(paths), args.force)
    if args.certificate is not None:
        check_certificate(args.certificate, len(paths), args.force, args.fault,
                          fault_margin_of(args) or 0.0)  # fmt: skip
    # one task of a method without workers (greedy, ...) needs no Ray: RAY_ADDRESS unchecked
    spreads = len(paths) > 1 or shares
    engine = Engine(args.workers, args.ray_address, local_default=1, option="--workers",
                    check_address=spreads or args.ray_address is not None)  # fmt: skip
    if len(paths) == 1 or not engine.use_ray:
        return solve_here(args, paths, engine)
    # a batch: tasks spread over the workers, each search in one process
    failed: list[Failed] = []
    printed = 0
    done: dict[int, object] = {}

    def show_in_order(i: int, outcome) -> None:
        nonlocal printed
        done[i] = outcome
        while printed in done:
            outcome = done.pop(printed)
            if isinstance(outcome, Failed):
                failed.append(outcome)
                report_error(outcome.error)
            else:
                print_result(args, paths[printed], *outcome)
            printed += 1

    with engine:
        engine.map(
            functools.partial(solve_file, spec, args.csv_header),  # Ray workers import it
            paths,
            labels=[str(p) for p in paths],
            catch=True,
            progress=shows_progress(args),
            desc="tasks",
            on_result=show_in_order,
        )
    return batch_status(failed, len(paths))


def solve_here(args: argparse.Namespace, paths: list[Path], engine) -> int:
    """Solve in this process, one task after the other (a single task's exhaustive search may
    still split its large levels over ``engine``'s workers; Ray starts once, at the first
    split level)."""
    split = engine if len(paths) == 1 and engine.use_ray else None
    failed = []
    with split or contextlib.nullcontext():
        for path in paths:
            failed += solve_path(args, path, split, single=len(paths) == 1)
    return batch_status(failed, len(paths))


def solve_path(args: argparse.Namespace, path: Path, engine, single: bool) -> list[Exception]:
    """Load, solve and print one task file (``engine``: see :func:`solver`); a file that
    cannot be read is reported (raised when it is the only one) and returned."""
    try:
        task = common.load_task(path, args.csv_header)
        common.check_task(task, path, palette(args))
    except (ValueError, OSError) as exc:
        if single:
            raise
        report_error(one_line(exc))
        return [exc]
    asked = engine is not None or (args.workers or 1) > 1 or args.ray_address is not None
    if single and args.method == "exhaustive" and asked:
        engine = split_engine(args, task, engine)
    if args.certificate is not None:
        check_certificate_levels(args, task)  # before the search
    result = solver(args, task, engine)(task)
    print_result(args, path, task, result)
    if args.export is not None:
        export_result(args, task, result)
    if args.certificate is not None:
        write_certificate(args, task, result)
    return []


def split_engine(args: argparse.Namespace, task, engine):
    """``engine`` where one task's exhaustive search splits its levels over workers; else None,
    and ``--workers`` above 1 or ``--ray-address`` refused, as for a method that takes no
    workers (the search over several module types, or of a task whose rotor wrenches depend
    on the structure, runs in this process: :func:`~modquad_gym.search.split.unsplit_reason`)."""
    from modquad_gym.search.problem import SearchProblem
    from modquad_gym.search.split import unsplit_reason

    why = unsplit_reason(SearchProblem(task, args.n_max, modules=palette(args)))
    if why is None:
        return engine
    dests = ["workers"] if (args.workers or 1) > 1 else []
    given.refuse_ignored(args, [*dests, "ray_address"], f"{why}: workers share several --task "
                         "files, or the levels of one task's one-type search")  # fmt: skip
    return None


def print_result(args: argparse.Namespace, path, task, result) -> None:
    """One solved task: a JSON line with ``--json``, else the structure drawn as a grid."""
    if getattr(args, "json", False):
        record = {"task": str(path), "name": task.name, **result.to_dict()}
        if result.fault is not None:
            record["worst_fault_margin"] = worst_fault_margin(task, result)
        print(json.dumps(record), flush=True)
        return
    print(f"task {task.name!r} ({path}): {task.describe()}, method {args.method}")
    print(f"  {result.status}: {result.describe(common.N_MAX_STEP)}")
    if result.structure is not None:
        print(f"  cells {list(result.structure.cells)}")
        if result.fault is not None:
            print(
                f"  survives any {result.fault} failure (worst margin over failures: "
                f"{worst_fault_margin(task, result):.4f})"
            )
        if result.palette:
            print(f"  module types: {[m.name for m in result.structure.modules]}")
        print("  " + result.structure.to_text().replace("\n", "\n  "))
    print(
        f"  configurations evaluated: {result.evaluated}, oracle calls: "
        f"{result.oracle_calls}, seconds: {result.seconds:.3f}",
        flush=True,
    )


def worst_fault_margin(task, result) -> float | None:
    """The smallest margin over every failure of ``result.fault`` and every wrench of
    ``task`` for the structure found (>= 0: it survives them all), None without a structure."""
    from modquad_gym.oracle.faults import fault_margin
    from modquad_gym.search.checker import LP_ROTORS

    if result.structure is None:
        return None
    W = task.rotor_wrenches(result.structure)
    rotors = result.structure.configuration_matrix().shape[1]
    method = "daqp" if rotors <= LP_ROTORS else "compiled"  # as the searches: no compilation
    margins = fault_margin(result.structure, W, task.f_max, fault=result.fault, method=method)
    return float(margins.min())
