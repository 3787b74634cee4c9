"""The leaderboard page's fixed sections: how the numbers are made and how to add an agent,
with what the rebuild checks in a submission and what it cannot."""

from __future__ import annotations

from benchmarks.leaderboard_entries import (
    ANYTIME,
    BUDGET,
    COMMAND,
    RESCORED,
    SUBMISSION,
    SUBMISSIONS,
)
from modquad_gym.tasks.reserved import HELDOUT_SEEDS, VALIDATION_SEEDS, span


def how_made(r: str) -> list[str]:
    """The page's section on where each number comes from (``r``: the path of ``results/``
    as written in the text)."""
    return [
        "## How the numbers are made",
        "",
        f"- **The budget**: a task counts within {BUDGET:g} s when the method's answer has the "
        f"optimal module count and its wall time on the task was at most {BUDGET:g} s (one "
        "run per task, without a time limit: a slower answer counts as none, as it would under "
        "the limit). Ties are broken by the optimal share without a limit, then by fewer "
        "seconds.",
        "- **Learned methods** (`ppo`: the shipped policy's deterministic pass and, with a model "
        "that sees greedy's choice, two more that share its start; `ppo-k8`: "
        "eight sampled rollouts more; `ppo-guided`: best-first search ordered by the policy, "
        "certified where its answer meets the lower bound): the five-seed reports "
        f"`{r}seeds_<tier>/seeds.csv`, one row per (seed, method, suite). Each seed's success, "
        "optimal share, configurations and seconds are pooled over the tier's tasks (suites "
        "weighted by their size), then averaged over the seeds; the interval is the 95 % "
        "percentile bootstrap over seeds (2,000 resamples, seeded). The seeds reports "
        f"(`{r}seeds_<tier>/seeds.md`) give the same mean, the interquartile mean of the same "
        "per-seed scores, and judge the tiers' goals. The five-seed files hold no per-task "
        "seconds or oracle calls: those two columns (‡) are the shipped model's one run in the "
        "tier report. The mixed and fault tiers' five seeds were scored before `ppo` took its "
        "two more passes below 16 modules (their models are not on this machine; each "
        "seeds.md says so): their `ppo` rows are the single pass, their tier reports' `ppo` "
        "(the shipped model) has the passes.",
        f"- **Searches**: the one-run tier reports `{r}tier_<tier>/benchmark.csv` (one row per "
        f"task), and `{r}{RESCORED}` for the searches a tier report did not run "
        f"(`{COMMAND} --rescore-searches --force`). `random` and `genetic` are seeded (seed 0).",
        "- **The fault tier**: only the methods that guarantee an answer surviving the failure "
        "are scored, and an answer counts only when it survives; milp refuses `fault=` (its row "
        "says so in place of numbers). The learned methods act with the tier's model, trained "
        "with the failure (their environment ends an episode only once every wrench survives, "
        "and each answer is verified), over five training seeds as on the other tiers. An "
        "outside agent is handed the problem "
        "with its fault and an evaluator that decides survival.",
        f"- **Anytime curves**: from the same per-task rows; the anytime search's history "
        f"(`{r}{ANYTIME}`, `{COMMAND} --anytime-history --force`) gives when its best structure so "
        "far first had the optimal count.",
        "- **Seconds** are wall time per task on the machine each source names (2 shared "
        "cores, no GPU): compare them within a tier, with care.",
        "",
    ]


def how_to_add(prefix: str) -> list[str]:
    """The page's section on adding a row: what to run, what to submit, how it is merged."""
    return [
        "## Add your own agent",
        "",
        "An agent is a class (or function) with `solve(task, evaluator)` that returns a "
        "structure; it is told each tier's `n_max`, `tier`, `modules` and the run's `seed` "
        "when its constructor takes them, and is counted through the evaluator it is handed: "
        "the protocol is in [Benchmark tiers and agents]("
        + ("" if prefix else "../docs/")
        + "benchmarks.md#score-your-own-agent). Its row is named by its own `name` attribute.",
        "",
        "**Reserved seeds.** The validation and held-out tasks are drawn with fixed seeds, and an "
        "environment reset with one draws the same task, its planted answer in `task.meta`: never "
        f"reset an environment, draw a task or train with a seed in {span(VALIDATION_SEEDS)} "
        f"(validation) or {span(HELDOUT_SEEDS)} (every tier's held-out suite), a vector "
        f"environment's seed + i included ([reserved seeds]({'' if prefix else '../docs/'}"
        "getting-started/agents.md#seeds-reserved-for-the-benchmark)). `reset` warns on one and "
        "`python train.py` refuses one; nothing in a score or a submission can detect it.",
        "",
        "**From the installed wheel** (no clone), score it on one tier beside the searches:",
        "",
        "```bash",
        "modquad score --tier current --solver my_agent:Agent --seed 0 --out my_scores",
        "```",
        "",
        "**A leaderboard row** needs a clone of the repository (`benchmarks/` is not in the "
        "wheel):",
        "",
        "```bash",
        f"{COMMAND} --solver my_agent:Agent --out my_board",
        "```",
        "",
        "scores it on every tier's held-out suites, once per seed (`--seeds`, default five "
        "like the learned methods; once when its constructor takes no `seed`), and writes "
        f"`my_board/leaderboard.md` with its rows ranked among the committed ones and "
        f"`my_board/{SUBMISSION}`: one row per (tier, seed, task). `--limit N` scores the first "
        "N tasks of each suite (the row is marked partial, with its task count); `--tiers` "
        "some tiers; a tier where the agent fails is reported as failed and the others are "
        "kept.",
        "",
        f"**To submit it**, open a pull request that adds `{SUBMISSION}` as "
        f"`results/{SUBMISSIONS}/<your agent>.csv`; the maintainers rebuild the page with "
        f"`{COMMAND} --force`, which reads every file of `results/{SUBMISSIONS}/` without a "
        "rerun: it verifies each row's cells again with the exact oracle against the tier's own "
        "task and takes the optimum from the suite (a row whose success or module count "
        "disagrees with its cells stops it, naming the file and the row). A submission holds "
        "one row per (seed, suite, task) and the same tasks in every seed; its task count is "
        "the number of distinct tasks (fewer than the tier's: partial). A repeated task (with the "
        "row it repeats), seeds with different tasks (the two seeds), a missing column or a row "
        "of an unknown tier is refused in one line naming the file and what is wrong, and so is "
        "an agent named like a committed method (compared without case, surrounding spaces or "
        "a parenthesised suffix) or with an invisible character.",
        "",
        "**What the rebuild cannot check.** An outside agent's seconds, configurations and "
        "oracle calls are the submitted ones: they are not measured again (seconds on the "
        f"submitter's machine), yet its seconds decide its rank (optimal within {BUDGET:g} s), "
        "so its time columns are marked § as self-reported. The built-in rows are measured by "
        "the commands named under each table. Nor can it tell how the seeds were chosen: "
        "identical seeds, or the best few of many, cannot be detected.",
        "",
    ]


if __name__ == "__main__":
    from benchmarks.common import refuse_as_script

    raise SystemExit(refuse_as_script("leaderboard_text"))
