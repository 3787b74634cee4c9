"""The RL stage of training: validation by optimal share (the kept model), the tasks PPO focuses
on (those the cloned policy misses), and a PPO run started from a saved cloned policy."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from agents.config import TrainConfig
from agents.focus import FocusedTasks, missed_tasks
from agents.validation import episode_optimal
from modquad_gym.envs.assembly import ModQuadAssemblyEnv
from modquad_gym.scoring.fine_tuning import best_index, kept_index
from modquad_gym.search import exhaustive_search
from modquad_gym.tasks import PlantedTasks, save_suite

torch = pytest.importorskip("torch")


def _evals(optimal, successes, returns) -> dict:
    rows = lambda v: np.array(v, dtype=float)[:, None].repeat(2, axis=1)  # noqa: E731
    return {"timesteps": np.arange(len(returns)) * 100, "results": rows(returns),
            "successes": rows(successes), "optimal": rows(optimal)}  # fmt: skip


def test_the_kept_evaluation_is_the_best_optimal_share_then_success_then_return():
    # the highest return loses to a higher optimal share; success breaks a tie of optima
    assert best_index(_evals([0.5, 0.5, 0.75, 0.75], [1, 1, 0.5, 1], [9, 9, 1, 0])) == 3
    assert best_index(_evals([0.5, 0.5, 0.5], [1, 1, 1], [1.0, 1.0 + 1e-12, 0.9])) == 0  # ties
    assert best_index(_evals([0.5, 0.5], [1, 1], [1.0, 1.1])) == 1  # then the return
    legacy = {k: v for k, v in _evals([0, 0], [1, 1], [1.0, 1.5]).items() if k != "optimal"}
    assert best_index(legacy) == 1  # a run before the optimal share: by its return


def test_an_episode_is_optimal_with_the_certified_count_or_when_none_exists():
    assert episode_optimal({"success": True, "n_modules": 3}, 3)
    assert not episode_optimal({"success": True, "n_modules": 4}, 3)
    assert not episode_optimal({"success": False, "n_modules": 3}, 3)
    assert episode_optimal({"success": False, "n_modules": 7}, None)


class FirstValid:
    """A policy that always docks the first valid action (wrong on half the tiny tasks)."""

    def predict(self, obs, action_masks, deterministic=True):
        return int(np.flatnonzero(action_masks)[0]), None


@pytest.fixture(scope="module")
def tiny_tasks() -> list:
    gen = PlantedTasks(n_modules=2, n_wrenches=24)
    return [gen(np.random.default_rng(s)) for s in range(6)]


def test_missed_tasks_are_those_a_plain_rollout_does_not_solve_optimally(tiny_tasks):
    env = ModQuadAssemblyEnv(tasks="planted", n_max=3)
    missed = missed_tasks(FirstValid(), env, tiny_tasks, n_max=3)
    reference = []
    for task in tiny_tasks:  # the same policy, played and judged by hand
        env.reset(options={"task": task})
        done = False
        while not done:
            _, _, term, trunc, info = env.step(int(np.flatnonzero(env.action_masks())[0]))
            done = term or trunc
        n_star = exhaustive_search(task, n_max=3).n_modules
        if not (info["success"] and info["n_modules"] == n_star):
            reference.append(task.name)
    assert [t.name for t in missed] == reference and 0 < len(missed) < len(tiny_tasks)


def test_focused_tasks_draw_the_missed_share_with_the_envs_rng(tiny_tasks):
    fresh = PlantedTasks(n_modules=3)
    missed = tiny_tasks[:2]
    draws = [FocusedTasks(fresh, missed, 30)(np.random.default_rng(s)) for s in range(400)]
    share = np.mean([any(d is m for m in missed) for d in draws])
    assert 0.22 < share < 0.38
    again = [FocusedTasks(fresh, missed, 30)(np.random.default_rng(s)) for s in range(5)]
    assert all(np.array_equal(a.wrenches, d.wrenches) for a, d in zip(again, draws))  # seeded
    none = FocusedTasks(fresh, [], 100)  # nothing missed: every task fresh
    assert all(none(np.random.default_rng(s)).n_wrenches != 24 for s in range(20))


def test_ppo_from_a_saved_cloned_policy_focuses_and_keeps_the_best_optimal_share(
    tmp_path, tiny_tasks
):
    """A run saves its cloned policy; a second run starts PPO from it, evaluates it at step 0,
    plays fresh tasks first and records the optimal share of every evaluation; its kept model
    is the evaluation best_index picks."""
    from agents.training import train

    suite = save_suite(tiny_tasks, tmp_path / "tiny.json")
    common = dict(task_source=str(suite), n_max=3, timesteps=512, eval_freq=256, n_eval=4,
                  tensorboard=tmp_path / "tb", progress=False)  # fmt: skip
    train(TrainConfig(out=tmp_path / "a", demo_tasks=6, bc_epochs=2, dagger_rounds=0, workers=1,
                      **common))  # fmt: skip
    cloned = tmp_path / "tb" / f"{tmp_path.name}-a" / "train" / "cloned_model.zip"
    assert cloned.is_file()
    train(TrainConfig(out=tmp_path / "b", init_from=cloned, focus_tasks=6, **common))
    config = json.loads((tmp_path / "b" / "config.json").read_text())
    assert config["imitation"] == {"init_from": str(cloned)}
    first = json.loads((tmp_path / "a" / "config.json").read_text())  # paths from the run folder
    assert (tmp_path / "a" / first["cloned_model"]).resolve() == cloned.resolve()
    assert (tmp_path / "a" / first["log_dir"]).resolve() == cloned.parent.resolve()
    assert (tmp_path / "b" / config["cloned_model"]).resolve() == cloned.resolve()
    assert (tmp_path / "b" / config["log_dir"] / "evaluations.npz").is_file()
    assert config["focus"]["tasks"] == 6 and 0 <= config["focus"]["missed"] <= 6
    evals = np.load(tmp_path / "b" / "evaluations.npz")
    assert evals["timesteps"][0] == 0 and evals["optimal"].shape == evals["results"].shape
    assert config["kept_model_timesteps"] == evals["timesteps"][kept_index(evals)]
    assert config["best_checkpoint_timesteps"] == evals["timesteps"][best_index(evals)]
    with pytest.raises(ValueError, match="--init-from"):
        TrainConfig(out=tmp_path / "c", init_from=cloned, resume=cloned)


def test_the_report_says_what_fine_tuning_did_in_optimal_designs(tmp_path):
    """With optimal shares recorded, the report's sentence counts optimal validation tasks and
    names the kept evaluation (the one best_index picks); no rise is never called one."""
    from modquad_gym.scoring.fine_tuning import fine_tuning_words

    def words(optimal, successes, returns) -> str:
        np.savez(tmp_path / "e.npz", **_evals(optimal, successes, returns))
        return fine_tuning_words(tmp_path / "e.npz")

    rose = words([0.5, 0.5, 1.0, 0.5], [1, 1, 1, 1], [1, 2, 1, 1])
    assert "from the cloned policy's 1 of 2 optimal at step 0, success 100.0 %" in rose
    assert "to 2 of 2 optimal at step 200, success 100.0 % (+1)" in rose
    assert "ended at 1 of 2 optimal at step 300" in rose
    flat = words([0.5, 0.5, 0.0], [1, 1, 1], [2, 1, 0])
    assert "did not solve more validation tasks optimally" in flat and "first one" in flat
    tie = words([0.5, 0.5, 0.0], [1, 1, 1], [1, 2, 0])  # a higher return, as many optima:
    assert "did not solve more" in tie and "that first one" in tie  # the start is kept


def _tiny_model(tmp_path, suite, kl_coef: float):
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.training import _new_model
    from modquad_gym.policy.ppo import make_env

    config = TrainConfig(out=tmp_path / "run", task_source=str(suite), n_max=3, seed=0,
                         tensorboard=tmp_path / "tb",
                         hyperparameters={"n_steps": 64, "batch_size": 32, "kl_coef": kl_coef,
                                          "learning_rate": 3e-3})  # fmt: skip
    venv = DummyVecEnv([lambda: make_env(**config.env_kwargs_full)])
    return _new_model(config, venv, None), venv


def test_the_kl_term_is_the_exact_divergence_and_holds_the_policy_near_its_anchor(
    tmp_path, tiny_tasks
):
    from agents.anchored_ppo import kl_divergence

    suite = save_suite(tiny_tasks, tmp_path / "tiny.json")
    model, venv = _tiny_model(tmp_path, suite, 0.0)
    model.set_anchor()
    obs = venv.reset()
    masks = np.stack(venv.env_method("action_masks"))
    obs_t, _ = model.policy.obs_to_tensor(obs)
    assert float(kl_divergence(model.policy, model.anchor, obs_t, masks)[0].detach()) == 0.0
    with torch.no_grad():  # move the policy; the reference KL over the valid actions by hand
        for p in model.policy.parameters():
            p.add_(0.5 * torch.randn_like(p))
    kl = float(kl_divergence(model.policy, model.anchor, obs_t, masks)[0].detach())
    logits = [m.get_distribution(obs_t, action_masks=masks).distribution.logits[0].detach()
              for m in (model.policy, model.anchor)]  # fmt: skip
    lp, lq = (torch.log_softmax(x[torch.as_tensor(masks[0])], 0).double() for x in logits)
    assert kl > 0 and kl == pytest.approx(float((lp.exp() * (lp - lq)).sum()), rel=1e-3)

    moved = {}
    for coef in (0.0, 100.0):  # the same seeded updates, with and without the term
        model, venv = _tiny_model(tmp_path, suite, coef)
        model.set_anchor()
        model.learn(256)
        obs_t, _ = model.policy.obs_to_tensor(venv.reset())
        masks = np.stack(venv.env_method("action_masks"))
        moved[coef] = float(kl_divergence(model.policy, model.anchor, obs_t, masks).mean().detach())
    assert moved[100.0] < moved[0.0]
    with pytest.raises(ValueError, match="ent_coef"):
        TrainConfig(out=tmp_path, hyperparameters={"kl_coef": 1.0, "ent_coef": 0.0})


def test_group_advantages_judge_each_episode_against_its_group():
    from agents.group_ppo import group_advantages

    assert np.array_equal(group_advantages([0.4, 0.4, 0.4]), np.zeros(3))  # alike: no update
    a = group_advantages([0.5, 0.4, 0.4, 0.3])
    assert a[0] > 0 > a[3] and a[1] == a[2] == 0 and np.std(a) == pytest.approx(1.0)


def test_group_ppo_fills_its_rollouts_with_sampled_groups(tmp_path, tiny_tasks):
    """With --advantage group a run's rollouts are groups of sampled episodes of one task: the
    buffer's advantages are the group-relative ones of its returns, and the run trains, keeps
    its best validation model and is deterministic."""
    from agents.training import train

    suite = save_suite(tiny_tasks, tmp_path / "tiny.json")
    common = dict(task_source=str(suite), n_max=3, timesteps=256, eval_freq=128, n_eval=3,
                  tensorboard=tmp_path / "tb", progress=False, workers=1, demo_tasks=6,
                  bc_epochs=1, dagger_rounds=0, advantage="group", group_size=4,
                  hyperparameters={"n_steps": 32, "batch_size": 16})  # fmt: skip
    params = []
    for name in ("a", "b"):
        train(TrainConfig(out=tmp_path / name, **common))
        from sb3_contrib import MaskablePPO

        params.append(MaskablePPO.load(tmp_path / name / "model.zip").policy.state_dict())
    assert all(torch.equal(params[0][k], params[1][k]) for k in params[0])
    config = json.loads((tmp_path / "a" / "config.json").read_text())
    assert config["timesteps"] >= 256 and "group" in config["command"]


def test_group_rollouts_hold_each_episode_with_its_groups_advantage(tmp_path, tiny_tasks):
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.group_ppo import group_advantages

    class Count(BaseCallback):
        def _on_step(self) -> bool:
            return True

    suite = save_suite(tiny_tasks, tmp_path / "tiny.json")
    model, venv = _tiny_model(tmp_path, suite, 0.0)
    model.set_sampler(ModQuadAssemblyEnv(tasks=str(suite), n_max=3, lookahead="exact"), 4, [0, 4])
    callback = Count()
    callback.init_callback(model)
    assert model.collect_rollouts(venv, callback, model.rollout_buffer, model.n_steps)
    buf = model.rollout_buffer
    starts = np.flatnonzero(buf.episode_starts.ravel()).tolist() + [buf.advantages.size]
    episodes = [(buf.returns.ravel()[a], buf.advantages.ravel()[a:b])
                for a, b in zip(starts, starts[1:])]  # fmt: skip
    full = len(episodes) // 4 - 1  # the last group may be cut by the buffer's end
    assert full >= 2 and callback.n_calls * venv.num_envs >= buf.advantages.size
    for g in range(full):
        group = episodes[4 * g : 4 * g + 4]
        expected = group_advantages([r for r, _ in group])
        for (_, adv), e in zip(group, expected):
            assert np.allclose(adv, e, atol=1e-6)  # every step of an episode: its advantage


def _flags(rows) -> dict:
    optimal = np.array(rows, dtype=bool)
    n = len(optimal)
    return {"timesteps": np.arange(n) * 100, "results": optimal.astype(float),
            "successes": np.ones_like(optimal, dtype=float), "optimal": optimal}  # fmt: skip


def test_the_cloned_start_is_kept_unless_the_best_checkpoint_beats_it_significantly(tmp_path):
    """A gain of 2 tasks out of 40 after 20 evaluations is luck's size (the start is kept);
    10 tasks gained and none lost is not (one-sided exact McNemar, Bonferroni over the
    evaluations), and the report says which."""
    from modquad_gym.scoring.fine_tuning import fine_tuning_words, replaces_start

    start = [True] * 30 + [False] * 10
    small = [_flags([start] * 5 + [[True] * 32 + [False] * 8] + [start] * 15)]
    big = [_flags([start] * 5 + [[True] * 40] + [start] * 15)]
    assert best_index(small[0]) == 5 and kept_index(small[0]) == 0
    assert best_index(big[0]) == 5 and kept_index(big[0]) == 5
    ok, p = replaces_start(big[0], 5)
    assert ok and p == pytest.approx(0.5**10)
    assert not replaces_start(small[0], 5)[0]
    np.savez(tmp_path / "small.npz", **small[0])
    words = fine_tuning_words(tmp_path / "small.npz")
    assert "(+2)" in words and "within chance for the best of 20 evaluations" in words
    assert "kept model is the cloned start" in words


def test_the_rl_stage_report_measures_each_gain_over_the_cloned_start():
    """The report's gains are run minus cloned start, per run and as a mean with its bootstrap
    interval; the curve's last-quarter level is one of them (a gain no choice inflates)."""
    from benchmarks.rl_stage import GAINS, gains

    cols = {c for pair in GAINS.values() for c in pair}
    rows = [{c: 0.9 for c in cols} for _ in range(3)]
    for row, last in zip(rows, (0.88, 0.89, 0.93)):
        row["val optimal, last quarter mean"] = last
    table = {g["gain (over cloned)"]: g for g in gains(rows)}
    assert set(table) == set(GAINS)
    curve = table["val optimal, last quarter mean"]
    assert curve["per run"] == "-2.0 -1.0 +3.0" and curve["mean"] == "+0.00 pt"
    low, high = (float(x) for x in curve["95 % CI"].strip("[]").split(","))
    assert -2.0 <= low < 0.0 < high <= 3.0
    assert table["held-out optimal"]["95 % CI"] == "[+0.00, +0.00]"  # nothing varies


def test_the_rl_stage_report_refuses_a_bad_run_before_any_held_out_pass(
    tmp_path, monkeypatch, capsys
):
    """Every RUN is read first: a folder lacking evaluations.npz or config.json, a config
    without its kept step or with another tier, evaluations that are no archive or lack the
    results or the optimal share (read by ``read_evaluations``, as ``score --train-dir``), a kept
    step no evaluation has, a missing cloned start or a run given twice is refused with one
    line naming the run, before the first run's held-out pass starts."""
    from benchmarks import rl_stage

    def make_run(name: str, **config) -> object:
        run = tmp_path / name
        run.mkdir()
        (run / "model.zip").write_bytes(b"")
        (tmp_path / "cloned.zip").write_bytes(b"")
        base = {"tier": "current", "seed": 0, "kept_model_timesteps": 100,
                "cloned_model": str(tmp_path / "cloned.zip")}  # fmt: skip
        (run / "config.json").write_text(json.dumps({**base, **config}))
        np.savez(run / "evaluations.npz", **_evals([0.5, 0.75], [1, 1], [1, 2]))
        return run

    def started(*args):
        raise AssertionError("a held-out pass started")

    monkeypatch.setattr(rl_stage, "heldout", started)
    good = make_run("good")
    assert rl_stage.read_run(good)[0]["seed"] == 0
    bad = {"no evaluations.npz": make_run("a"), "config.json unreadable": make_run("b"),
           "has no tier, seed or kept_model_timesteps": make_run("c", kept_model_timesteps=None),
           "names tier 'nope'": make_run("d", tier="nope"),
           "evaluations.npz: no 'results' array": make_run("e"),
           "records no optimal or successes": make_run("i"),
           "is no evaluation's step": make_run("f", kept_model_timesteps=150),
           "its cloned start": make_run("g", cloned_model=str(tmp_path / "gone.zip")),
           "evaluations.npz: not a NumPy .npz archive": make_run("h")}  # fmt: skip
    (bad["evaluations.npz: not a NumPy .npz archive"] / "evaluations.npz").write_text("garbage")
    (bad["no evaluations.npz"] / "evaluations.npz").unlink()
    (bad["config.json unreadable"] / "config.json").write_text("{not json")
    config = json.loads(
        (bad["has no tier, seed or kept_model_timesteps"] / "config.json").read_text()
    )
    del config["kept_model_timesteps"]
    (bad["has no tier, seed or kept_model_timesteps"] / "config.json").write_text(
        json.dumps(config)
    )
    np.savez(bad["evaluations.npz: no 'results' array"] / "evaluations.npz", timesteps=[0, 100])
    np.savez(bad["records no optimal or successes"] / "evaluations.npz", timesteps=[0, 100],
             results=[[1.0], [1.5]])  # fmt: skip
    for message, run in bad.items():
        argv = [str(good), str(run), "--out", str(tmp_path / "out")]
        with pytest.raises(ValueError, match=message) as err:
            rl_stage.main(argv)
        assert "\n" not in str(err.value) and str(run) in str(err.value)
    again = tmp_path / "x" / ".." / "good"  # the same folder, spelt otherwise
    (tmp_path / "x").mkdir()
    with pytest.raises(SystemExit) as stop:  # argparse's refusal: one line, exit 2
        rl_stage.main([str(good), str(again), "--out", str(tmp_path / "out")])
    assert stop.value.code == 2
    assert f"argument RUN: {again} is given twice" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_rl_stage_plays_the_best_checkpoint_the_run_records_from_any_folder(
    tmp_path, monkeypatch
):
    """A run's config.json records its log folder and cloned start relative to the run folder:
    rl_stage plays that best_model.zip from any working folder (logs outside ./runs too); an
    older config's best checkpoint lies beside its cloned start; a best checkpoint that is not
    the kept model and cannot be found is refused in one line naming the run and the file,
    never scored with the kept model's numbers."""
    from benchmarks import rl_stage

    played = []

    def heldout(model, tier):
        played.append(Path(model).resolve())
        return 0.5, 1.0

    monkeypatch.setattr(rl_stage, "heldout", heldout)
    logs = tmp_path / "elsewhere" / "tb" / "x-run" / "train"
    logs.mkdir(parents=True)
    for name in ("cloned_model.zip", "best_model.zip"):
        (logs / name).write_bytes(b"")
    run = tmp_path / "runs" / "run"
    run.mkdir(parents=True)
    (run / "model.zip").write_bytes(b"")
    np.savez(run / "evaluations.npz", **_evals([0.5, 0.75, 0.5], [1, 1, 1], [1, 2, 1]))
    base = {"tier": "current", "seed": 0, "kept_model_timesteps": 0}  # best: step 100
    (run / "config.json").write_text(json.dumps({**base, "log_dir": "../../elsewhere/tb/x-run/"
                                                 "train", "cloned_model": "../../elsewhere/tb/"
                                                 "x-run/train/cloned_model.zip"}))  # fmt: skip
    monkeypatch.chdir(tmp_path / "elsewhere")  # no runs/ here
    rl_stage.main([str(run), "--out", str(tmp_path / "out")])
    assert played == [logs / "cloned_model.zip", run / "model.zip", logs / "best_model.zip"]
    older = {**base, "cloned_model": str(logs / "cloned_model.zip")}  # absolute, no log_dir
    (run / "config.json").write_text(json.dumps(older))
    played.clear()
    rl_stage.main([str(run), "--out", str(tmp_path / "out2")])
    assert played[-1] == logs / "best_model.zip"
    (logs / "best_model.zip").unlink()
    with pytest.raises(ValueError, match="best checkpoint") as err:
        rl_stage.main([str(run), "--out", str(tmp_path / "out3")])
    assert str(run) in str(err.value) and str(logs / "best_model.zip") in str(err.value)
    assert "\n" not in str(err.value) and not (tmp_path / "out3").exists()
