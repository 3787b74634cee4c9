"""What several ``modquad`` commands share: reading a task file, the module palette, the options
that recur (``--method`` and its companions from the one solver table, ``--workers``,
``--csv-header``, ``--modules``, ``--force``) and the one-line error text."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from modquad_gym.core.options import int_option, nonempty_option, real_option, seed_option
from modquad_gym.methods import REGISTRY
from modquad_gym.policy.models import UNTRUSTED
from modquad_gym.search.options import NONE_HELP
from modquad_gym.search.problem import DEFAULT_TIME_LIMIT
from modquad_gym.tasks import CSV_HEADER_MODES

N_MAX_OPTION = int_option(1, 2**63 - 1)
"""``--n-max``: any positive integer parses; each search says how far it can go."""

MAX_WORKERS = 256
"""Most processes ``solve --workers`` accepts."""

MODULES_HELP = (
    "comma-separated module types to mix, one per cell, chosen by the search "
    "(stock names: t45 = the paper's T-module, t45m = its mirrored tilts, t30, t30m = "
    "30-degree tilts, flat = an untilted quadrotor); e.g. t45,t45m,flat. "
    "Default: every module is the paper's T-module"
)

Command = Callable[[argparse.Namespace], int]


def load_task(path, csv_header: str = "auto"):
    """The task in the file ``path`` (``--csv-header`` says how a CSV's first row reads; the
    other files of a --task that holds a CSV file are read without it): a TaskRequirement, or a
    DynamicTask for a JSON file with a trajectory. A static task's scale is checked as the
    searches will (an error names the file and the 1-based row); a CSV or .npy file of more
    wrenches than a search takes is refused before it is parsed."""
    from modquad_gym.oracle import check_task_scale
    from modquad_gym.search.size import MAX_SEARCH_WRENCHES as MOST
    from modquad_gym.search.size import search_size_message
    from modquad_gym.tasks import TaskFileError, TaskRequirement
    from modquad_gym.tasks import load_task as load
    from modquad_gym.tasks.loading import wrenches_at_most
    from modquad_gym.tasks.wrenches import MAX_WRENCHES

    if not str(path).lower().endswith(".csv"):  # refused where no file is (given.py)
        csv_header = "auto"
    n = wrenches_at_most(path, csv_header)  # more than a search takes: before parsing
    if n is not None and n > MOST:
        count = f"more than {MAX_WRENCHES:,}" if n > MAX_WRENCHES else f"{n:,}"
        raise TaskFileError(f"{path}: {search_size_message(count)}")
    task = load(path, csv_header=csv_header)
    if isinstance(task, TaskRequirement):
        try:
            check_task_scale(task.wrenches, task.f_max)
        except ValueError as exc:
            raise TaskFileError(f"{path}: {exc}") from None
    return task


def check_task(task, path=None, modules=None) -> None:
    """Checks before any work. A dynamic task (its wrenches depend on the structure) is
    refused when no structure of the module types ``modules`` (default the T-module) can lift
    its payload (a TaskFileError naming the file ``path``). A task of more wrenches than a
    search takes (a dynamic one: more distinct samples): TaskFileError naming the file. Every
    method takes both kinds of task."""
    from modquad_gym.search.size import check_search_size
    from modquad_gym.tasks import TaskFileError

    if getattr(task, "kind", None) == "dynamic":
        from modquad_gym.dynamics import check_liftable
        from modquad_gym.geometry.structure import Structure

        try:
            check_liftable(task, modules or [Structure([(0, 0)]).module])
        except ValueError as exc:
            if path is None:
                raise
            raise TaskFileError(f"{path}: {exc}") from None
    if path is not None:
        try:
            check_search_size(task.decision_model.base, dynamic=task.per_structure)
        except ValueError as exc:
            raise TaskFileError(f"{path}: {exc}") from None


def palette_of(text: str | None, repeats: bool = False):
    """``--modules`` text as a list of module types (a type twice only with ``repeats``), or
    None when not given."""
    if text is None:
        return None
    from modquad_gym.geometry.module import palette

    try:
        return palette(text, repeats=repeats)
    except ValueError as exc:  # "modules: ..." -> "--modules: ..."
        raise ValueError(f"--{exc}") from None


def palette(args: argparse.Namespace):
    """``--modules`` as a list of module types, or None when not given: the palette a search
    mixes (each type once), or beside ``--cells`` one type per cell (types repeat)."""
    return palette_of(getattr(args, "modules", None), repeats=bool(getattr(args, "cells", None)))


def check_simulable_types(args: argparse.Namespace) -> None:
    """A ValueError (``--modules: module type ...``) when a type of ``--modules`` has an inertia
    MuJoCo cannot compile (:func:`~modquad_gym.sim.inertial.check_simulable`): for the
    commands that simulate or export a model, before any search."""
    types = palette(args)
    if not types:
        return
    from modquad_gym.sim.inertial import check_simulable

    try:
        check_simulable(types)
    except ValueError as exc:
        raise ValueError(f"--modules: {exc}") from None


def add_command(sub, name: str, func: Command, help: str, description: str):
    """A subcommand parser of ``sub`` that runs ``func(args)``."""
    parser = sub.add_parser(name, help=help, description=description)
    parser.set_defaults(func=func)
    return parser


def add_n_max(p: argparse.ArgumentParser, help: str) -> None:
    p.add_argument("--n-max", type=N_MAX_OPTION, default=7, help=help)


def time_limit_option(text: str) -> float:
    """An argparse ``type`` for ``--time-limit``: seconds in (0, one day]."""
    from modquad_gym.search.problem import check_time_limit

    try:
        return check_time_limit(real_option(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace("time_limit ", "")) from None


time_limit_option.__name__ = "seconds"


def f_max_option(text: str) -> float:
    """An argparse ``type`` for ``--f-max`` (every command's): a rotor thrust limit in N, in
    1e-300..1e12, the range every task's f_max is checked against
    (:func:`~modquad_gym.core.validation.check_f_max`)."""
    from modquad_gym.core.validation import check_f_max

    try:
        return check_f_max(real_option(text))
    except ValueError as exc:  # "f_max = 1e+301 is outside ..." -> "1e+301 is outside ..."
        text = str(exc).removeprefix("f_max = ").removeprefix("f_max ")
        raise argparse.ArgumentTypeError(text) from None


f_max_option.__name__ = "newtons"


def add_method(
    p: argparse.ArgumentParser, default: str = "anytime", modules_help: str = MODULES_HELP
) -> None:
    """``--method`` (choices and help from the solver table), ``--n-max``, ``--time-limit``,
    ``--model``, ``--seed`` and ``--modules`` (help ``modules_help``)."""
    p.add_argument(
        "--method",
        default=default,
        metavar="{" + ",".join(REGISTRY) + "}",
        type=method_option,
        help="; ".join(f"{name}: {m.help}" for name, m in REGISTRY.items())
        + "; also ppo-kN (N sampled rollouts) and ppo-guided-bN-wN (budget, branching) "
        "(default %(default)s)",
    )
    add_n_max(
        p,
        "largest module count (default %(default)s; the exhaustive search goes up to 16, "
        "every other search up to 128)",
    )
    p.add_argument(
        "--time-limit",
        type=time_limit_option,
        default=DEFAULT_TIME_LIMIT,
        metavar="SECONDS",
        help="seconds a search may take, in (0, 86400] (default %(default)s; neither compiling "
        "kernels, once after an install, nor Ray's start, `solve --workers N`, is counted): the "
        "anytime search stops earlier when its lower bound meets the structure found; "
        "centrosymmetric, beam, genetic, greedy and random return what they have found by then",
    )
    p.add_argument(
        "--model",
        default=None,
        help="PPO model .zip for --method ppo/ppo-guided (default: the model shipped with the "
        "package, modquad_gym/data/models/ppo_default/model.zip, and for one module type from "
        "--n-max 16 on ppo_scale, trained further on tasks of 8-32 modules; for a dynamic task of "
        "one module type the one trained on motions, modquad_gym/data/models/ppo_dynamic). A model "
        "is read without unpickling (its NumPy actor, model_actor.npz, or the weights and spaces "
        "of a policy the package knows); one that only unpickling reads is "
        f"refused unless --trust-model is given: {UNTRUSTED}",
    )
    p.add_argument(
        "--trust-model",
        action="store_true",
        help="load a --model .zip that only unpickling reads (a policy class or keywords the "
        f"package does not know): {UNTRUSTED}, so give it only for a file you trust",
    )
    seeded = [name for name, m in REGISTRY.items() if "seed" in m.options.names()]
    p.add_argument(
        "--seed",
        type=seed_option,
        default=0,
        help=f"seed of the random draws of {', '.join(seeded)} (ppo: its sampled rollouts, "
        "ppo-kN), 0 to 2**63-1 (default %(default)s); refused for the other methods and ppo "
        "without samples, which draw nothing at random",
    )
    add_modules(p, modules_help)
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        default=None,
        help="set one of the method's own options (repeat for several), e.g. beam_width=8 for "
        "beam, population=48 for genetic, budget=128 for ppo-guided, prune=true for the "
        "constructive methods (greedy, random, beam, genetic, ppo, ppo-guided: then drop the "
        "modules the answer does not need); an option the method does not take is refused, "
        "naming the ones it takes (the docs' method table lists them), and so is one given "
        "twice or beside the flag that gives it (--seed, --time-limit); model is --model, and "
        "objects (start, engine, producers) are given in Python (make_solver). " + NONE_HELP,
    )


def method_option(text: str) -> str:
    """An argparse ``type`` for ``--method``: a registered method or a learned variant."""
    from modquad_gym.methods import method_of

    try:
        method_of(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


method_option.__name__ = "method"


FAULT_KINDS = ("rotor", "module", "rotor2", "rotor+module")
"""The choices of ``--fault`` (:data:`modquad_gym.oracle.faults.FAULTS`, without importing it)."""

NO_FAULT = ", ".join(name for name, m in REGISTRY.items() if not m.fault)
"""The methods that cannot honour ``--fault`` (the registry's word), for the help texts."""

FAULT_HELP = (
    "the answer must keep doing the task after any failure of this kind: rotor (any one rotor "
    "stops), module (any one module's rotors stop; it stays docked and its weight still "
    "counts), rotor2 (any two rotors stop) or rotor+module (a module's rotors and one rotor of "
    f"another module stop). Every method but {NO_FAULT} takes it (the learned ones, for a "
    "rotor failure of T-modules alone below --n-max 16, with the model trained with it, "
    "modquad_gym/data/models/ppo_fault, otherwise zero-shot; each answer is verified to "
    "survive); "
    "--json adds fault and worst_fault_margin (the smallest margin over the failures and "
    "wrenches, >= 0)"
)


def add_detection_delay(p: argparse.ArgumentParser, help: str) -> None:
    """``--detection-delay SECONDS`` (the required fault margin derived from it)."""
    p.add_argument(
        "--detection-delay", type=real_option, default=None, metavar="SECONDS", help=help
    )


def add_fault(p: argparse.ArgumentParser, help: str = FAULT_HELP) -> None:
    """``--fault {rotor,module,rotor2,rotor+module}`` (the failure an answer must survive) and
    ``--fault-margin`` (the worst margin it must keep after it)."""
    p.add_argument("--fault", choices=FAULT_KINDS, default=None, help=help)
    p.add_argument(
        "--fault-margin",
        type=real_option,
        default=None,
        metavar="MU",
        help="with --fault: the worst margin (1 - gamma, as worst_fault_margin) every task "
        "wrench must keep after the failure, in [0, 1) (default 0): thrust to spare while the "
        "controller does not yet know of the failure. --detection-delay picks it from the delay",
    )


def fault_margin_of(args: argparse.Namespace) -> float | None:
    """The required fault margin of the command line: ``--fault-margin``, else the one
    :func:`~modquad_gym.oracle.faults.margin_for_delay` derives from a ``--detection-delay``
    given for the design (None: no margin asked). ValueError for both, or either without
    ``--fault``."""
    from modquad_gym.oracle.fault_delay import check_delay
    from modquad_gym.oracle.faults import check_fault_margin, margin_for_delay

    margin = getattr(args, "fault_margin", None)
    delay = getattr(args, "detection_delay", None)
    if margin is not None and delay is not None:
        raise ValueError("give --fault-margin or --detection-delay, not both")
    if margin is None and delay is None:
        return None
    if getattr(args, "fault", None) is None:
        raise ValueError(
            f"{'--fault-margin' if margin is not None else '--detection-delay'} applies with "
            "--fault"
        )
    if margin is not None:
        try:
            return check_fault_margin(margin, args.fault)
        except ValueError as exc:
            raise ValueError(f"--fault-margin {margin:g}: {exc}") from None
    return margin_for_delay(check_delay(delay, "--detection-delay"), args.fault)


def check_fault_method(args: argparse.Namespace) -> None:
    """``--fault`` with a method that cannot honour it: before any work, the words Python's
    :func:`~modquad_gym.solvers.make_solver` uses."""
    from modquad_gym.methods import method_of, refused_fault

    fault, method = getattr(args, "fault", None), getattr(args, "method", None)
    if fault is not None and method is not None and not method_of(method)[0].fault:
        raise ValueError(refused_fault(method_of(method)[0].name, fault))


def add_csv_header(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--csv-header",
        choices=CSV_HEADER_MODES,
        default="auto",
        help="how a CSV task file's first row is read: auto (a row of names is a header; a "
        "row 0,1,2,3,4,5, as pandas writes column numbers, is refused as ambiguous), yes "
        "(skip the first row), no (every row is a wrench) (default %(default)s)",
    )


def add_workers(p: argparse.ArgumentParser, default: str) -> None:
    p.add_argument(
        "--workers",
        type=int_option(1, MAX_WORKERS),
        default=None,
        help=f"parallel Ray tasks, 1 to {MAX_WORKERS} (1: everything in this process, no Ray); "
        f"default {default}",
    )
    p.add_argument(
        "--ray-address",
        type=nonempty_option,
        default=None,
        metavar="ADDRESS",
        help="join this Ray cluster (HOST:PORT of `ray start --head`, or auto) instead of an "
        "embedded Ray on this machine (default: $RAY_ADDRESS)",
    )


def add_modules(p: argparse.ArgumentParser, help_text: str = MODULES_HELP) -> None:
    p.add_argument("--modules", default=None, metavar="TYPES", help=help_text)


def add_force(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--force", action="store_true", help="replace existing output files (default: refuse)"
    )


def print_help(parser: argparse.ArgumentParser) -> Command:
    """A command function that prints ``parser``'s help (for a command given no action)."""

    def show(args) -> int:
        parser.print_help()
        return 0

    return show


N_MAX_STEP = "try --n-max {n} or more"  # an infeasible answer's next step (SearchResult.describe)


def no_structure(args: argparse.Namespace, outcome: str, result=None) -> ValueError:
    """The error of a command that writes a file of the structure ``--method`` finds for
    ``--task`` (export, show) when it finds none, with what ``result`` proved: the file asked
    for is not written, so the run fails (exit 2) where ``modquad solve`` succeeds."""
    infeasible = result is not None and result.status == "infeasible"
    proved = f" ({result.proved_note(N_MAX_STEP)})" if infeasible else ""
    return ValueError(
        f"--task: {args.method} found no structure of up to {args.n_max} modules for "
        f"{args.task}{proved}; {outcome}"
    )


def report_error(message: str) -> None:
    """``modquad: error: MESSAGE`` on stderr, at once."""
    print(f"modquad: error: {message}", file=sys.stderr, flush=True)


def batch_status(failed: list, total: int) -> int:
    """The exit code of a batch: 0, or 2 after a line counting the failed tasks."""
    if not failed:
        return 0
    print(f"modquad: error: {len(failed)} of {total} tasks failed (above)", file=sys.stderr)
    return 2
