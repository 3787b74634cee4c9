"""The benchmark report's line about the PPO model scored: how it was trained, from the
``config.json`` of its training run (each fact the file records; none it does not)."""

from __future__ import annotations

from pathlib import Path


def shown(path: Path) -> str:
    """``path`` relative to the working folder where it lies below it (shorter in reports)."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def model_line(cfg: dict, model: Path) -> str:
    """How the PPO model at ``model`` was trained, from its training run's ``config.json``."""
    imitation = cfg.get("imitation")
    cloned = (
        f"behaviour cloning on {imitation['expert_episodes']} expert episodes "
        f"({imitation['states']} states, {imitation['epochs']} epochs; demonstrations "
        f"{imitation['collect_seconds']} s, cloning {imitation['clone_seconds']} s), then "
        if imitation
        else ""
    )
    if rounds := (imitation or {}).get("dagger"):
        cloned += (f"{len(rounds)} rounds of the expert in the loop (DAgger: "
                   f"{sum(r['states'] for r in rounds)} learner states labelled by the certified "
                   f"search; {imitation['dagger_seconds']} s), then ")  # fmt: skip
    return (
        f"PPO model: `{shown(model)}` ({cfg.get('policy', 'MultiInputPolicy')}): {cloned}"
        f"MaskablePPO{training(cfg)}. `ppo` decodes deterministically; "
        "`ppo-kN` adds N seeded sampled rollouts and keeps the smallest verified structure "
        "(configurations evaluated count the distinct structures over all rollouts)."
    )


def training(cfg: dict) -> str:
    """The PPO run's facts that ``cfg`` records, in the report's words (a config.json without
    them is said to record none, never printed as ``None``)."""

    def said(text: str, *keys: str) -> str:
        values = {key: facts.get(key) for key in keys}
        return text.format(**values) if None not in values.values() else ""

    facts = {**cfg, "seconds": cfg.get("ppo_seconds", cfg.get("wall_seconds")),
             "tasks": cfg.get("env_kwargs", {}).get("tasks")}  # fmt: skip
    speed = [said("{steps_per_second} steps/s", "steps_per_second"),
             said("{n_envs} envs", "n_envs"), said("torch threads {torch_threads}",
                                                   "torch_threads")]  # fmt: skip
    speed_text = ", ".join(filter(None, speed))
    steps = said("{timesteps} training steps", "timesteps") + said(" in {seconds} s", "seconds")
    steps += f" ({speed_text})" if speed_text else ""
    kept = [said("task source `{tasks}`", "tasks"),
            said("kept: {kept_model} (step {kept_model_timesteps})", "kept_model",
                 "kept_model_timesteps")]  # fmt: skip
    parts = [steps.strip(), said("training wall time {wall_seconds} s in all", "wall_seconds"),
             ", ".join(filter(None, kept))]  # fmt: skip
    run = "; ".join(filter(None, parts))
    return f", {run}" if run else " (its config.json records no training run)"
