"""Solvers of the registered methods: :func:`make_solver`, the one factory, and the solvers it
makes (a search, a learned method). Torch and SB3 load only when a learned solver is made with
a model that has no fresh NumPy actor (:mod:`modquad_gym.policy.inference`)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any, Protocol, runtime_checkable

from modquad_gym.geometry.structure import Structure
from modquad_gym.methods import REGISTRY, Method, Options, method_of, refused_fault
from modquad_gym.policy.models import SCALE_FROM, default_model, one_default_type, shipped_model
from modquad_gym.search import SearchResult
from modquad_gym.search.options import check_seed
from modquad_gym.search.problem import DEFAULT_N_MAX, MAX_MODULES, SearchProblem, check_palette
from modquad_gym.search.prune import pruned
from modquad_gym.solvers.outside import load_solver
from modquad_gym.solvers.problems import problem_for, problem_settings, refuse_start

METHOD_HELP = {name: m.help for name, m in REGISTRY.items()}
"""The built-in methods' one-line help (read from :data:`~modquad_gym.methods.REGISTRY`, which
is what the CLI, :func:`make_solver` and ``modquad score`` read)."""
METHODS = tuple(METHOD_HELP)
"""The built-in methods' names (besides the variants of the learned ones)."""
LEARNED = tuple(name for name, m in REGISTRY.items() if m.extra == "train")


@runtime_checkable
class Solver(Protocol):
    """Anything with a ``name`` that turns a task or a :class:`SearchProblem` into a verified
    :class:`SearchResult`."""

    name: str

    def solve(self, task: Any) -> SearchResult: ...


class MethodSolver:
    """A registered method with its checked options: ``solve(problem)`` honours every field of
    the problem or refuses it (:meth:`~modquad_gym.methods.Method.check`). A task that is not a
    problem becomes one with the ``n_max``, ``modules`` and ``fault`` given to
    :func:`make_solver`; a problem that says otherwise than one of them is refused
    (:func:`~modquad_gym.solvers.problems.problem_for`)."""

    def __init__(self, method: Method, settings: Options, defaults: dict) -> None:
        self.method = method
        self.name = method.name
        self.settings = settings
        self.defaults = defaults
        self.n_max = defaults.get("n_max", DEFAULT_N_MAX)

    def problem(self, task: Any) -> SearchProblem:
        """The problem the method acts on (checked against what it can honour)."""
        problem = problem_for(task, self.defaults)
        self.method.check(problem)
        return problem

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, {self.settings!r}, {self.defaults!r})"


class SearchSolver(MethodSolver):
    """A search of :mod:`modquad_gym.search` behind the :class:`Solver` interface (the anytime
    search on an engine with Ray gets the learned policy among its producers)."""

    def solve(self, task: Any) -> SearchResult:
        from modquad_gym.search import SEARCHES

        options = self.settings.as_dict()
        engine = options.get("engine")
        if self.method.name == "anytime" and getattr(engine, "use_ray", False):
            if options.get("producers") is None:
                from modquad_gym.policy.guided import producers_with_policy

                options["producers"] = producers_with_policy()
        return SEARCHES[self.method.name](self.problem(task), **options)


class LearnedSolver(MethodSolver):
    """A learned method (``ppo`` or ``ppo-guided``): the policy acts on the problem's budget
    and palette, with the shipped model of that budget and palette unless ``model`` is given
    (:func:`~modquad_gym.policy.default_model`; the T-module named alone is one type, as no
    palette is). A task whose wrenches carry the structure's weight is acted on with its one
    type's module set (:func:`~modquad_gym.policy.policy.acting_palette`, as the anytime
    search's policy producer does). With a problem's ``fault=`` it designs for that failure
    (:meth:`~modquad_gym.policy.Policy.use_fault`; one type, a rotor failure and a budget below
    :data:`~modquad_gym.policy.models.SCALE_FROM`: with the fault tier's model, trained with it;
    else zero-shot) and verifies that every answer survives it."""

    def __init__(self, method: Method, settings: Options, defaults: dict) -> None:
        super().__init__(method, settings, defaults)
        self.kind = method.name
        self._solvers: dict[tuple, Any] = {}
        modules = self.defaults.get("modules")  # checked as a problem checks it: one message
        self._default = (
            self.defaults.get("n_max", 7),
            None if modules is None else check_palette(None, modules),
            None,
            (self.defaults.get("fault"), self.defaults.get("fault_margin") or 0.0),
        )
        self.inner(*self._default)  # load now

    def inner(
        self, n_max: int, palette: list | None, tier: str | None = None, fault: tuple = (None, 0.0)
    ) -> Any:
        """The PPO or guided solver of this budget, palette (None: one type) and ``fault``
        (the failure and the margin required after it), made once; without ``model``, the
        shipped model of the task's tier (``tier``: a dynamic task of one type acts with the
        model trained on motions), of a rotor failure, or of the budget and palette."""
        key = (n_max, tuple(m.digest for m in palette or ()), tier, fault)
        if key not in self._solvers:
            if n_max > MAX_MODULES:  # the environment's grid (the searches' limit)
                raise ValueError(
                    f"n_max={n_max} is beyond what the {self.kind} method can act on: at most "
                    f"{MAX_MODULES} modules (see `modquad solve --help`)"
                )
            with model_named("model"):
                self._solvers[key] = self._made(n_max, palette, tier, fault)
        return self._solvers[key]

    def _made(self, n_max: int, palette: list | None, tier: str | None, fault: tuple) -> Any:
        """A new PPO or guided solver (see :meth:`inner`)."""
        options = self.settings.as_dict()
        options.pop("prune")
        model = options.pop("model")
        one_type = one_default_type(palette)  # the T-module alone, named or not: one model
        if model is None and tier is not None and one_type:
            model = shipped_model(tier)
        elif model is None and fault[0] == "rotor" and one_type and n_max < SCALE_FROM:
            model = shipped_model("fault")  # the fault tier's: trained with that failure
        model = default_model(n_max, palette) if model is None else model
        if self.kind == "ppo-guided":
            from modquad_gym.policy.guided import GuidedSolver

            solver: Any = GuidedSolver(model=model, n_max=n_max, fault=fault[0],
                                       fault_margin=fault[1], **options)  # fmt: skip
        else:
            from modquad_gym.policy.ppo import PPOSolver

            solver = PPOSolver(model=model, n_max=n_max, fault=fault[0],
                               fault_margin=fault[1], **options)  # fmt: skip
        if solver.n_max != n_max:
            raise ValueError(
                f"the loaded policy acts with n_max={solver.n_max}, not n_max={n_max} (give "
                "a model path, or a problem of that budget)"
            )
        solver.policy.use_palette(palette)
        return solver

    def __getattr__(self, name: str) -> Any:
        """The default budget's PPO or guided solver answers the rest (``policy``, ``dive``,
        ``budget``, ...)."""
        if name.startswith("_") or name in ("defaults", "settings"):
            raise AttributeError(name)
        return getattr(self.inner(*self._default), name)

    def solve(self, task: Any) -> SearchResult:
        from modquad_gym.policy.policy import acting_palette

        problem = self.problem(task)
        palette = acting_palette(problem)  # a self-weight task: its one type's module set
        tier = problem.task.policy_tier
        failure = (problem.fault, problem.fault_margin)
        result = self.inner(problem.n_max, palette, tier, failure).solve(problem.task)
        result.method = self.name
        if palette is not None and not problem.typed:  # one type, acted on as a module set
            result.palette = ()
            if result.structure is not None:
                result.structure = Structure(result.structure.cells, module=palette[0])
        if not self.settings.prune:
            return result
        return pruned(result, problem, self.settings.time_limit)


def make_solver(
    method: str,
    n_max: int = DEFAULT_N_MAX,
    model: Any = None,
    seed: int | None = None,
    samples: int | None = None,
    modules=None,
    guided: dict | None = None,
    tier: str | None = None,
    fault: str | None = None,
    fault_margin: float | None = None,
    **options: Any,
) -> Solver:
    """The one factory of solvers, read from :data:`~modquad_gym.methods.REGISTRY`: ``method``
    is a registered name, a variant of a learned one (``ppo-kN``: N sampled rollouts besides
    the deterministic one; ``ppo-guided[-bN][-wN][-nodive]``: budget N, branching N, no dive)
    or ``package.module:Name`` (an outside agent, :func:`load_solver`, told ``n_max``,
    ``tier``, ``modules``, ``fault`` and ``seed``; ``tier`` is for outside agents only).

    ``n_max`` (default 7), ``modules`` (a palette), ``fault`` and ``fault_margin`` (the worst
    margin required after the failure), checked here, make the :class:`SearchProblem` of a
    task handed to ``solve``; a problem handed to ``solve`` is used as it is, and refused
    where it says otherwise than one of them that was given (ValueError naming both).
    ``model``, ``seed``, ``samples``, ``guided`` (a dict of ppo-guided's options) and
    ``options`` are the method's options, each given once: one it does not take is refused
    (TypeError naming it and the ones it takes), and so is a ``fault`` it cannot honour
    (ValueError), in Python as on the command line."""
    if not isinstance(method, str):
        raise TypeError(f"method must be a method name (str), got {method!r}")
    named = {"model": model, "seed": seed, "samples": samples}
    if ":" in method:
        return _outside(method, n_max, modules, fault, fault_margin, tier, named, guided, options)
    entry, variant = method_of(method)
    if tier is not None:
        raise TypeError(
            f"tier={tier!r}: method {method!r} does not take it (tier tells an outside agent, "
            "package.module:Name, its benchmark tier); give the tier's n_max, modules and fault"
        )
    settings = entry.settings(**_method_options(method, entry.name, variant, named, guided,
                                                options))  # fmt: skip
    if fault is not None and not entry.fault:
        raise ValueError(refused_fault(entry.name, fault))
    defaults = problem_settings(n_max, modules, fault, fault_margin)
    if (refusal := beyond_reach(entry, defaults["n_max"])) is not None:
        raise ValueError(refusal)
    if getattr(settings, "start", None) is not None:  # what the settings given fix, now
        refuse_start(settings.start, defaults)
    solver = entry.solver(settings, defaults)
    samples = getattr(settings, "samples", 0)
    solver.name = f"ppo-k{samples}" if method == "ppo" and samples else method  # a variant's
    return solver


def draws_at_random(method: str) -> bool:
    """Whether the registered ``method`` (or a variant: ``ppo-kN``) draws at random, so that a
    seed is its option: one that takes ``seed``, ppo only with sampled rollouts."""
    entry, variant = method_of(method)
    names = entry.options.names()
    return "seed" in names and ("samples" not in names or variant.get("samples", 0) > 0)


def beyond_reach(method: Method, n_max: int, flag: str | None = None) -> str | None:
    """Why ``n_max`` is beyond ``method``'s reach (its ``max_modules``: 16 for exhaustive, else
    128), in Python's words (``n_max=17 is beyond ...``) or, given ``flag``, the command line's
    (``--n-max 17: ...``); None within reach. :func:`make_solver` refuses it when the solver is
    made, the command line before any file is read."""
    if n_max <= method.max_modules:
        return None
    verb, most = ("act on" if method.extra == "train" else "search"), method.max_modules
    if flag is not None:
        return f"{flag} {n_max}: method {method.name!r} can {verb} at most {most} modules"
    return (f"n_max={n_max} is beyond what the {method.name} method can {verb}: at most {most} "
            "modules (see `modquad solve --help`)")  # fmt: skip


def _method_options(method: str, name: str, variant: dict, named: dict, guided: Any,
                    options: dict) -> dict:  # fmt: skip
    """The options of ``method`` given through its variant's name, ``guided``, ``options`` and
    the named keywords (``model``, ``seed``, ``samples``): one given twice is refused, and so
    is one that contradicts what the variant's name sets."""
    if guided is not None and name != "ppo-guided":
        raise TypeError(f"guided= gives ppo-guided's options; method {method!r} takes its "
                        "options as keywords")  # fmt: skip
    if guided is not None and not isinstance(guided, dict):
        raise TypeError(f"guided must be a dict of ppo-guided's options, got {guided!r}")
    sources = [(f"guided={{{k!r}: {v!r}}}", k, v) for k, v in (guided or {}).items()]
    named = {k: v for k, v in named.items() if v is not None}  # None: not given
    sources += [(f"{k}={v!r}", k, v) for k, v in {**options, **named}.items()]
    given: dict = {}
    said: dict = {}
    for text, key, value in sources:
        if key in given:
            raise ValueError(f"{key} is given twice ({said[key]} and {text}); give it once")
        given[key], said[key] = value, text
    for key, value in variant.items():  # its name says what it does: an option cannot unsay it
        if key in given and given[key] != value:
            raise ValueError(
                f"method {method!r} sets {key}={value!r}; {key}={given[key]!r} contradicts it "
                f"(give method {name!r} with {key}={given[key]!r})"
            )
        given[key] = value
    return given


def _outside(method: str, n_max: Any, modules: Any, fault: Any, fault_margin: Any, tier: Any,
             named: dict, guided: Any, options: dict) -> Solver:  # fmt: skip
    """The outside agent ``method`` (``package.module:Name``), told the checked budget,
    module types, fault, tier and seed; the options of a registered method are refused (it
    would never see them)."""
    extra = {k: v for k, v in named.items() if v is not None and k != "seed"}
    extra.update(options, **({} if guided is None else {"guided": guided}))
    extra.update({} if fault_margin is None else {"fault_margin": fault_margin})
    if extra:
        key = next(iter(extra))
        raise TypeError(
            f"{key}={extra[key]!r}: {method!r} is an outside agent, told only n_max, modules, "
            "fault, tier and seed"
        )
    settings = problem_settings(n_max, modules, fault)
    seed = None if named["seed"] is None else check_seed(named["seed"], "seed")
    return load_solver(method, n_max=settings["n_max"], tier=tier, modules=settings["modules"],
                       fault=settings["fault"], seed=seed)  # fmt: skip


@contextmanager
def model_named(name: str) -> Iterator[None]:
    """A ValueError about the model file (the policy names it ``--model PATH: ...``, as the
    command line's flag, and its advice ``--trust-model``) raised inside the block names them as
    the door does: ``model`` and ``trust_model=True`` for the Python door, ``--model`` and
    ``--trust-model`` for the command line's (which makes its solvers here too)."""
    try:
        yield
    except ValueError as exc:
        text = str(exc)
        for said in ("--model ", "--model:", "model ", "model:"):
            if text.startswith(said):
                text = name + said.removeprefix("--").removeprefix("model") + text[len(said) :]
                trust = "--trust-model" if name.startswith("--") else "trust_model=True"
                for other in ("--trust-model", "trust_model=True"):
                    text = text.replace(f"give {other}", f"give {trust}")
                for other in ("--model ", "model "):
                    text = text.replace(f"give {other}", f"give {name} ")
                raise ValueError(text) from exc
        raise


def learned_options(method: str) -> tuple[str, dict] | None:
    """(learned method, the options its variant sets) of a learned method name or variant (see
    :func:`make_solver`); None for any other name; ValueError for a malformed variant."""
    if ":" in method:
        return None
    try:
        entry, variant = method_of(method)
    except ValueError:
        if method.startswith("ppo-"):
            raise
        return None
    return (entry.name, variant) if entry.extra == "train" else None


def guided_options(method: str) -> dict:
    """The guided-search options of ``ppo-guided[-bN][-wN][-nodive]`` (see :func:`make_solver`)."""
    entry, variant = method_of(method)
    if entry.name != "ppo-guided":
        raise ValueError(f"bad method {method!r}: not a ppo-guided variant")
    return variant
