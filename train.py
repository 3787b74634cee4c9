"""Train the PPO agent of modquad_gym and write its benchmark report.

``python train.py`` runs the recipe of :mod:`agents.training` (behaviour cloning on
certified expert episodes, then MaskablePPO; <= 30 min on 2 CPU cores) on the ``current`` tier
(``ModQuadAssembly-v0``, n_max 7) into a new run folder ``runs/<name>/`` (default
``ppo-seed<seed>``: ``model.zip``, ``config.json``, ``evaluations.npz`` and the benchmark report
in ``report/``); it refuses a run folder that exists unless ``--force``.

* ``--tier large`` trains on the large tier (n_max 12, its own task source and held-out suite),
  ``--tier mixed`` on the mixed one (three module types: each action docks a (cell, type)).
* ``--seeds 0 1 2 3 4`` trains one run per seed as parallel Ray tasks (an embedded Ray on the
  local cores, or the cluster of ``RAY_ADDRESS``), each into ``<out>/seed-S``; ``python -m
  modquad_gym.scoring.seeds`` then reports them over seeds (IQM with 95 % bootstrap intervals).
* ``--publish`` also installs the model as its tier's shipped model
  (``modquad_gym/data/models/ppo_default/`` on the current tier, ``ppo_<tier>/`` on others) and
  writes the report into ``results/`` (``results/tier_<tier>/``); ``--publish-run RUN`` does
  that for a run trained before (one named seed of ``--seeds``) without training.
* ``--quick`` is a short smoke run (a few thousand steps) into ``runs/quick``.
"""

from modquad_gym.core.interrupts import run_command


def main(argv: list[str] | None = None) -> int:
    """:func:`agents.cli.main`, imported here, not at the script's start: a Ctrl-C while its
    modules (torch, Stable-Baselines3) load ends as one during training does."""
    from agents.cli import main as train

    return train(argv)


if __name__ == "__main__":  # Ctrl-C or SIGTERM: one line, exit 130 or 143
    raise SystemExit(run_command(main, "python train.py"))
