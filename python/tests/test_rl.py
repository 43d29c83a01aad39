"""Issue 17: normalized observations, ``loomlab.evaluate`` against ``loomlab run``'s scoring, and the
training entry point's plumbing (pure numpy: CI installs no torch)."""

from __future__ import annotations

import csv
import json
import os
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import loomlab
from loomlab import _native
from loomlab.evaluation import evaluate, load_policy, markdown_table
from loomlab.train import main as train_main

ESCAPE_DEFAULT = os.path.join(os.path.dirname(loomlab.__file__), "scenarios", "escape_default.toml")


@pytest.mark.parametrize("env_id", ["loomlab/Escape-v0", "loomlab/EscapeDiscrete-v0"])
@pytest.mark.parametrize("obs_mode", ["raw", "normalized", "privileged"])
@pytest.mark.parametrize("observe_frames", [False, True])
def test_check_env_passes_for_every_obs_mode(short_kwargs, env_id, obs_mode, observe_frames):
    env = gym.make(env_id, obs_mode=obs_mode, observe_frames=observe_frames, **short_kwargs).unwrapped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env)
    obs, _ = env.reset(seed=3)
    if obs_mode != "raw":
        features = obs["features"] if observe_frames else obs
        assert features.dtype == np.float32 and features.shape == (len(env._native.feature_names),)
    env.close()


def test_normalized_space_declares_every_feature_and_its_bounds(short_kwargs):
    env = loomlab.EscapeEnv(obs_mode="normalized", **short_kwargs)
    names = env._native.feature_names
    assert names[:2] == ["hopfield.log_output", "soc.log_output"]
    assert {"theta_hat_rad", "theta_hat_rate_rps", "hopfield.alarm", "robot.y", "robot.time"} <= set(names)
    space = env.observation_space
    assert isinstance(space, gym.spaces.Box) and np.all(np.isfinite(space.low)) and np.all(np.isfinite(space.high))
    assert space.high[names.index("theta_hat_rad")] == pytest.approx(np.pi)
    assert _native.FEATURE_SCALES["theta_rate_limit_rps"] == space.high[names.index("theta_hat_rate_rps")]
    with pytest.raises(loomlab.ScenarioError, match="obs_mode"):
        loomlab.EscapeEnv(obs_mode="scaled", **short_kwargs)


def test_normalized_features_stay_in_bounds_on_the_env_scenario_set():
    """Every episode of the env's default scenario set (two expansions), with cruising, dodging and
    stopping agents: every feature is finite and inside the declared bounds (the Rust test
    `normalized_features_stay_in_bounds_on_the_default_scenarios` covers the default suite)."""
    opts = loomlab.env.options_json(
        loomlab.env.build_options(frame_size=32, action_type="discrete", obs_mode="normalized")
    )
    steps = 0
    for seed in (0, 5):
        native = _native.EscapeEnv.from_suite(None, seed, None, opts)
        low, high = np.asarray(native.feature_low), np.asarray(native.feature_high)
        for i in range(native.num_episodes):
            obs, _ = native.reset_to_episode(i)
            done = False
            while not done:
                assert np.all(np.isfinite(obs)) and np.all(obs >= low) and np.all(obs <= high), obs
                obs, _, term, trunc, _ = native.step_discrete(i % 4)
                steps += 1
                done = term or trunc
    assert steps > 1000


@pytest.mark.parametrize("action_type", ["continuous", "discrete"])
def test_vector_env_gives_the_single_envs_normalized_features(short_kwargs, action_type):
    n = 3
    vec = loomlab.EscapeVectorEnv(n, obs_mode="normalized", action_type=action_type, **short_kwargs)
    singles = [loomlab.EscapeEnv(obs_mode="normalized", action_type=action_type, **short_kwargs) for _ in range(n)]
    obs, _ = vec.reset(seed=10)
    assert vec.observation_space.contains(obs)
    for i, env in enumerate(singles):
        o, _ = env.reset(seed=10 + i)
        np.testing.assert_array_equal(obs[i], o)
    for t in range(30):
        if action_type == "discrete":
            actions = np.array([(t // 10 + i) % 4 for i in range(n)], dtype=np.int64)
        else:
            actions = np.tile(np.array([0.3, 0.0, 0.5 * np.sin(t)], dtype=np.float32), (n, 1))
        obs, *_ = vec.step(actions)
        assert vec.observation_space.contains(obs), t
        for i, env in enumerate(singles):
            if env._native.closed:
                continue
            o, _, term, trunc, _ = env.step(actions[i])
            np.testing.assert_array_equal(obs[i], o)
            if term or trunc:
                env.close()
    fresh, _ = vec.reset_envs([1])
    assert fresh.shape == (1, len(vec._native.feature_names))
    vec.close()


# --- evaluate() is `loomlab run` plus the policy's row --------------------------------------------
SAME_KEYS = [
    "episodes",
    "hits",
    "misses",
    "false_alarms",
    "correct_rejections",
    "hit_rate",
    "false_alarm_rate",
    "collisions",
    "collision_rate",
    "hit_rate_ci",
    "false_alarm_rate_ci",
    "collision_rate_ci",
    "evadable_threats",
    "unavoidable_threats",
    "evaded",
    "evasion_rate",
    "evasion_rate_ci",
    "late_misses",
    "silent_misses",
    "hit_collisions",
    "false_alarm_collisions",
    "collision_reduction",
    "mean_lead_s",
]


@pytest.fixture(scope="module")
def threshold_evaluation():
    """The threshold controller (the shadow controller of hopfield, the first detector) evaluated on
    the env's default scenario set at n = 32, and `loomlab run` (in-process) on the same episodes."""
    kw = dict(seeds=[3], limit=6, frame_size=32, action_type="discrete", jobs=2, progress=False)
    report = evaluate(load_policy("threshold"), ESCAPE_DEFAULT, label="threshold_policy", **kw)
    shipped = evaluate(load_policy("threshold"), None, label="threshold_policy", **kw)
    run = loomlab.run_suite(ESCAPE_DEFAULT, seed=3, size=32, limit=6, jobs=2)
    return report, shipped, run


def test_evaluate_report_is_loomlab_runs_plus_the_policy_row(threshold_evaluation):
    report, shipped, run = threshold_evaluation
    assert set(report) >= set(run) and report["seeds"] == [3]
    assert report["episodes"] == run["episodes"] == 6
    assert report["references"] == run["references"] == ["null", "oracle", "ideal_theta", "ideal_tau", "ideal_course"]
    assert set(report["detectors"]) == set(run["detectors"]) | {"threshold_policy"}
    for label, summary in run["detectors"].items():
        assert report["detectors"][label] == summary, label
    for label, summary in shipped["detectors"].items():
        assert report["detectors"][label] == summary, f"shipped name vs path: {label}"


def test_a_threshold_policy_scores_as_loomlab_run_scores_its_detector(threshold_evaluation):
    report, _, run = threshold_evaluation
    mine, theirs = report["detectors"]["threshold_policy"], run["detectors"]["hopfield"]
    for key in SAME_KEYS:
        assert mine[key] == theirs[key], f"{key}: policy {mine[key]} vs loomlab run hopfield {theirs[key]}"
    # the sample exercises both classes of episodes and the evasion of threats
    assert mine["hits"] + mine["misses"] > 0 and mine["false_alarms"] + mine["correct_rejections"] > 0
    table = markdown_table(report, "threshold_policy")
    assert table.splitlines()[2].startswith("| threshold_policy | 6 |")


def test_a_cruising_policy_scores_as_the_null_row(threshold_evaluation):
    report, _, _ = threshold_evaluation
    cruise = evaluate(
        lambda obs, info: 0, ESCAPE_DEFAULT, seeds=[3], limit=6, frame_size=32, label="cruise", progress=False
    )
    for key in ("hits", "misses", "false_alarms", "collisions", "collision_rate", "evaded"):
        assert cruise["detectors"]["cruise"][key] == report["detectors"]["null"][key], key


def test_evaluate_rejects_reserved_labels_and_empty_seeds():
    with pytest.raises(loomlab.ScenarioError, match="reference row"):
        evaluate(lambda o, i: 0, ESCAPE_DEFAULT, seeds=[0], limit=1, frame_size=32, label="oracle", progress=False)
    with pytest.raises(ValueError, match="seeds"):
        evaluate(lambda o, i: 0, seeds=[], progress=False)


# --- the training entry point (pure numpy CEM: the same loop, logs, checkpoints and resume as PPO) --
def _train(out, *extra):
    train_main(
        [
            "--algo",
            "cem",
            "--action-repeat",
            "1",
            "--dodge-hold-s",
            "0",
            "--n-envs",
            "2",
            "--frame-size",
            "32",
            "--max-episode-steps",
            "25",
            "--eval-every",
            "50",
            "--eval-seeds",
            "1000",
            "--eval-limit",
            "2",
            "--seed",
            "4",
            "--out",
            str(out),
            *extra,
        ]
    )


def _progress(out):
    with open(os.path.join(out, "progress.csv")) as f:
        return list(csv.DictReader(f))


def test_training_logs_checkpoints_resumes_and_repeats_under_a_seed(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _train(a, "--timesteps", "100")
    rows = _progress(a)
    assert [int(r["steps"]) for r in rows] == [0, 50, 100]
    latest = json.loads((a / "checkpoints" / "latest.json").read_text())
    assert latest["steps"] == 100 and os.path.exists(latest["path"])
    with pytest.raises(SystemExit, match="already holds a run"):
        _train(a, "--timesteps", "100")
    _train(a, "--timesteps", "150", "--resume")
    rows = _progress(a)
    assert [int(r["steps"]) for r in rows] == [0, 50, 100, 150]
    with pytest.raises(SystemExit, match="differs"):
        train_main(["--algo", "cem", "--seed", "5", "--resume", "--out", str(a), "--timesteps", "200"])
    # same seed, same curve: a fresh run repeats the first one's evaluations and parameters
    _train(b, "--timesteps", "100")
    keys = ["steps", "collision_rate", "unnecessary_dodge_rate", "hit_rate"]
    assert [[r[k] for k in keys] for r in _progress(b)] == [[r[k] for k in keys] for r in _progress(a)[:3]]
    za, zb = np.load(a / "checkpoints" / "step_100.npz"), np.load(b / "checkpoints" / "step_100.npz")
    np.testing.assert_array_equal(za["mean"], zb["mean"])
    # the checkpoint is a policy loomlab.evaluate can score
    policy = load_policy(str(b / "checkpoints" / "step_100.npz"), "discrete")
    rep = evaluate(policy, ESCAPE_DEFAULT, seeds=[1000], limit=2, frame_size=32, label="cem", progress=False)
    assert rep["detectors"]["cem"]["episodes"] == 2


def test_training_on_a_suite_with_decision_features_repeats_under_a_seed(tmp_path):
    """`make rl-result`'s configuration (the default suite's rows' decision features, the escape
    controller's manoeuvres, every K-th held-out episode), short: same seed, same curve and weights."""

    def run(out):
        train_main(
            ["--algo", "cem", "--scenario", "suite:default", "--tiers", "0", "--obs", "decision"]
            + ["--env", "manoeuvre", "--n-envs", "2", "--frame-size", "32", "--max-episode-steps", "6"]
            + ["--timesteps", "24", "--eval-every", "12", "--eval-seeds", "1000", "--eval-stride", "120"]
            + ["--eval-limit", "240", "--seed", "3", "--out", str(out)]
        )

    a, b = tmp_path / "a", tmp_path / "b"
    run(a)
    run(b)
    rows = _progress(a)
    assert [int(r["steps"]) for r in rows] == [0, 12, 24]
    assert {int(r["episodes"]) for r in rows} == {2}, "every 120th of the first 240 held-out episodes"
    keys = ["steps", "collision_rate", "unnecessary_dodge_rate", "hit_rate"]
    assert [[r[k] for k in keys] for r in rows] == [[r[k] for k in keys] for r in _progress(b)]
    za, zb = np.load(a / "checkpoints" / "step_24.npz"), np.load(b / "checkpoints" / "step_24.npz")
    np.testing.assert_array_equal(za["mean"], zb["mean"])
    assert za["mean"].size % 6 == 0, "six manoeuvre actions"


def test_training_arguments_are_checked(tmp_path):
    with pytest.raises(SystemExit, match="--eval-stride must be >= 1"):
        train_main(["--algo", "cem", "--eval-stride", "0", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit, match="--eval-seeds"):
        train_main(["--algo", "cem", "--eval-seeds", "9-3", "--out", str(tmp_path / "x")])
    with pytest.raises(SystemExit, match="no checkpoint"):
        train_main(["--algo", "cem", "--resume", "--out", str(tmp_path / "none")])


def test_ppo_training_repeats_under_a_seed_and_resumes(tmp_path):
    """The PPO path (skipped where stable-baselines3 is not installed, as in `make test`; run it in
    the RL venv: `make rl-env`, then pytest with `.venv-rl/bin/python`)."""
    pytest.importorskip("stable_baselines3")
    import zipfile

    def ppo(out, *extra):
        train_main(
            ["--algo", "ppo", "--n-envs", "2", "--n-steps", "32", "--batch-size", "32", "--n-epochs", "2"]
            + ["--frame-size", "32", "--max-episode-steps", "20", "--eval-every", "64", "--eval-seeds", "1000"]
            + ["--eval-limit", "2", "--seed", "9", "--out", str(out), *extra]
        )

    a, b = tmp_path / "a", tmp_path / "b"
    ppo(a, "--timesteps", "128")
    ppo(b, "--timesteps", "128")
    # the learnability check's path: the privileged percept after a curriculum phase
    c, d = tmp_path / "c", tmp_path / "d"
    for out in (c, d):
        ppo(out, "--timesteps", "128", "--obs", "privileged", "--curriculum-steps", "64")
    with (
        zipfile.ZipFile(c / "checkpoints" / "step_128.zip") as zc,
        zipfile.ZipFile(d / "checkpoints" / "step_128.zip") as zd,
    ):
        assert zc.read("policy.pth") == zd.read("policy.pth"), "same seed, same weights (privileged, curriculum)"
    curve = ["steps", "collision_rate", "unnecessary_dodge_rate", "hit_rate"]
    assert [[r[k] for k in curve] for r in _progress(c)] == [[r[k] for k in curve] for r in _progress(d)]
    keys = ["steps", "collision_rate", "unnecessary_dodge_rate", "hit_rate"]
    assert [[r[k] for k in keys] for r in _progress(a)] == [[r[k] for k in keys] for r in _progress(b)]
    with (
        zipfile.ZipFile(a / "checkpoints" / "step_128.zip") as za,
        zipfile.ZipFile(b / "checkpoints" / "step_128.zip") as zb,
    ):
        assert za.read("policy.pth") == zb.read("policy.pth"), "same seed, same weights"
    ppo(a, "--timesteps", "192", "--resume")
    assert [int(r["steps"]) for r in _progress(a)] == [0, 64, 128, 192]
    assert os.path.exists(tmp_path / "a" / "sb3" / "progress.csv")


# --- issue 28: the environment designed to be learned --------------------------------------------
def test_privileged_observation_is_the_true_percept_and_action_repeat_holds_the_action(short_kwargs):
    env = loomlab.EscapeEnv(obs_mode="privileged", action_type="discrete", action_repeat=4, **short_kwargs)
    names = env._native.feature_names
    assert names[:3] == ["threat.theta_rad", "threat.theta_rate_rps", "threat.inv_tau_ps"]
    assert len(names) == 17 and "threat.miss_radii" in names and "robot.time" in names
    obs, info = env.reset(seed=2)
    assert env.observation_space.contains(obs)
    steps = 0
    while True:
        obs, _, term, trunc, info = env.step(0)
        steps += 1
        assert env.observation_space.contains(obs)
        if term or trunc:
            break
    assert info["step"] == min(4 * steps, env._native.duration_steps) or info["collision"]
    assert "timely_dodge" in info["reward_terms"]
    with pytest.raises(loomlab.ScenarioError, match="action_repeat"):
        loomlab.EscapeEnv(action_repeat=0, **short_kwargs)
    env.close()


def test_curriculum_scenario_has_larger_slower_balls():
    from loomlab.train import curriculum_toml

    base = loomlab.scenario_toml("escape_default")
    easy = curriculum_toml(base)
    assert "radius_m = 0.25" in easy and "speed_mps = 6" in easy
    assert '"world.projectiles.0.speed_mps" = { min = 4.8, max = 8.4 }' in easy
    env = loomlab.EscapeEnv(scenario_toml=easy, frame_size=32)
    env.close()
    with pytest.raises(SystemExit, match="no projectile"):
        curriculum_toml('name = "x"\n')


def test_training_on_the_privileged_percept_with_a_curriculum_repeats_under_a_seed(tmp_path):
    """The numpy learner (no torch: this runs in `make test`) on the privileged observation, the
    default action repeat and a curriculum phase: same seed, same parameters and the same curve."""

    def cem(out):
        train_main(
            ["--algo", "cem", "--obs", "privileged", "--dodge-hold-s", "0", "--n-envs", "2", "--frame-size", "32"]
            + ["--max-episode-steps", "24", "--eval-every", "12", "--eval-seeds", "1000", "--eval-limit", "2"]
            + ["--curriculum-steps", "12", "--seed", "6", "--timesteps", "24", "--out", str(out)]
        )

    a, b = tmp_path / "a", tmp_path / "b"
    cem(a)
    cem(b)
    ra, rb = _progress(a), _progress(b)
    assert [int(r["steps"]) for r in ra] == [0, 12, 24], "3 decisions per episode, 2 episodes per generation"
    keys = ["steps", "collision_rate", "unnecessary_dodge_rate", "hit_rate"]
    assert [[r[k] for k in keys] for r in ra] == [[r[k] for k in keys] for r in rb]
    za, zb = np.load(a / "checkpoints" / "step_24.npz"), np.load(b / "checkpoints" / "step_24.npz")
    np.testing.assert_array_equal(za["mean"], zb["mean"])
    assert za["mean"].shape == (18 * 4,), "17 privileged features + bias, 4 actions"
    config = json.loads((a / "config.json").read_text())
    assert (config["obs"], config["action_repeat"]) == ("privileged", 8)


def test_a_held_dodge_is_one_decision(short_kwargs):
    env = loomlab.EscapeEnv(action_type="discrete", action_repeat=4, dodge_hold_s=0.1, **short_kwargs)
    env.reset(seed=1)
    assert env.step(0)[4]["step"] == 4
    assert env.step(1)[4]["step"] == 16, "a dodge: 0.1 s = 12 camera periods in one step"
    with pytest.raises(loomlab.ScenarioError, match="dodge_hold_s"):
        loomlab.EscapeEnv(dodge_hold_s=-1.0, **short_kwargs)
    env.close()
