"""``modquad solve``'s output files: ``--export`` (the structure found, as MJCF, URDF or JSON)
and ``--certificate`` (the proof of a certified answer), each checked before the search and
written after it."""

from __future__ import annotations

import argparse
from pathlib import Path

from modquad_gym.cli.common import palette


def check_outputs_differ(args: argparse.Namespace) -> None:
    """``--certificate`` and ``--export`` naming one file: refused before any search (the
    second would replace the first)."""
    if args.export is None or args.certificate is None:
        return
    if Path(args.export).resolve() == Path(args.certificate).resolve():
        raise ValueError(
            f"--certificate {args.certificate} and --export {args.export} name the same file; "
            "give two files"
        )


def check_export(out: str, n_tasks: int, force: bool) -> None:
    """``--export`` is checked before any search: one task, a known suffix, its extra (MJCF
    needs MuJoCo), a writable file."""
    from modquad_gym.core.extras import require
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.sim.export import SUFFIXES

    if n_tasks != 1:
        raise ValueError(f"--export: give one task, not {n_tasks} (it writes one structure)")
    if Path(out).suffix.lower() not in SUFFIXES.values():
        raise ValueError(
            f"--export: {out} must end in {', '.join(SUFFIXES.values())} (MJCF, URDF, JSON)"
        )
    if Path(out).suffix.lower() == SUFFIXES["mjcf"]:
        require("mujoco")  # the [sim] extra, before the search rather than after it
    check_output_file(out, force=force, what="--export")


def export_result(args: argparse.Namespace, task, result) -> None:
    """Write the structure found to ``--export`` (the task's f_max in the model)."""
    from modquad_gym.sim.export import save_structure

    if result.structure is None:
        raise ValueError(f"--export: no structure found for {task.name!r}; nothing written")
    out = save_structure(  # a file that appeared during the search: refused in these words
        result.structure, args.export, f_max=task.f_max, force=args.force, what="--export"
    )
    if not args.json:
        print(f"  wrote {out}")


def check_certificate(
    out: str, n_tasks: int, force: bool, fault: str | None, fault_margin: float = 0.0
) -> None:
    """``--certificate`` is checked before any search: one task, a fault model it covers
    (no margin after the failure), .json(.gz), a writable file."""
    from modquad_gym.core.outputs import check_output_file
    from modquad_gym.search.certificates import CertificateError, check_fault

    try:
        check_fault(fault, fault_margin)
    except CertificateError as e:
        raise ValueError(f"--certificate: {e}") from None
    if n_tasks != 1:
        raise ValueError(f"--certificate: give one task, not {n_tasks} (it proves one answer)")
    if not out.endswith((".json", ".json.gz")):
        raise ValueError(f"--certificate: {out} must end in .json or .json.gz")
    check_output_file(out, force=force, what="--certificate")


def check_certificate_levels(args: argparse.Namespace, task) -> None:
    """``--certificate``'s levels, checked once the task is read, before the search: refused
    at once when every certified answer's certificate must prove a level it cannot (one below
    the search's proved bound, too large and covered by no level bound); when only the
    certificate of a larger answer (or of none) would be refused, a note says so now rather
    than after the search (:func:`~modquad_gym.search.certificates.check_levels`)."""
    from modquad_gym.core.notes import note
    from modquad_gym.search.certificates import CertificateError, check_levels
    from modquad_gym.search.problem import SearchProblem

    problem = SearchProblem.build(task, args.n_max, modules=palette(args), fault=args.fault)
    try:
        level = check_levels(problem)
    except CertificateError as e:
        raise ValueError(f"--certificate: {e}") from None
    if level is not None:
        note(f"modquad: note: --certificate: level {level} holds too many structures to "
             "prove one by one and no level bound covers it: the certificate of an answer of "
             f"more than {level} modules, or of none up to {args.n_max}, will be refused after "
             "the search", __name__)  # fmt: skip


def write_certificate(args: argparse.Namespace, task, result) -> None:
    """Write the certificate of a certified answer to ``--certificate``
    (:mod:`modquad_gym.search.certificates`)."""
    from modquad_gym.search.certificates import write
    from modquad_gym.search.problem import SearchProblem

    if not result.certified:
        raise ValueError(
            f"--certificate: the answer for {task.name!r} is not certified (proved bound "
            f"{result.lower_bound}, {result.n_modules or 'no'} modules); nothing written: "
            f"{certifying_advice(args, task)}"
        )
    problem = SearchProblem.build(task, args.n_max, modules=palette(args), fault=args.fault)
    out = write(result, problem, args.certificate, force=args.force, what="--certificate")
    if not args.json:
        print(f"  wrote {out}")


def certifying_advice(args: argparse.Namespace, task) -> str:
    """What may certify an answer that is not: a method that certifies where it finishes
    (anytime, milp, exhaustive) ends uncertified only on its time limit, so a longer
    ``--time-limit``; any other (a learned method, a heuristic) the default search; the
    exhaustive search too where ``--n-max`` is within its reach
    (:func:`~modquad_gym.search.typed.exhaustive_reach`)."""
    from modquad_gym.methods import method_of
    from modquad_gym.search.typed import exhaustive_reach

    entry = method_of(args.method)[0]
    types = palette(args) or [None]
    weighed = task.decision_model.uses_mass or task.decision_model.uses_inertia
    reach = exhaustive_reach(len(types), shape_only=len(types) == 1 and not weighed)
    exhaustive = args.n_max <= reach and entry.name != "exhaustive"
    also = " or --method exhaustive" if exhaustive else ""
    if entry.certifies and entry.timed:
        return f"give a longer --time-limit{also}"
    return f"give --method anytime (the default, which certifies where it finishes){also}"
