"""``python -m loomlab.train``: train a policy on the detector signals (normalized observations).

Algorithms:

- ``ppo`` (default): Stable-Baselines3 PPO with an MLP policy (optional extra ``loomlab[rl]``:
  ``pip install 'loomlab[rl]'`` brings stable-baselines3, torch, tensorboard, tqdm);
- ``cem``: a pure-numpy cross-entropy method over a linear policy, with no optional dependency
  (the plumbing test of CI; also a sanity baseline).

Both run on the native vector environment (``loomlab.EscapeVectorEnv``) of
``loomlab/EscapeDiscrete-v0`` (``--env discrete``) or ``loomlab/Escape-v0`` (``--env continuous``),
seeded by ``--seed``, observing the detector features (``--obs detectors``: ``obs_mode="normalized"``)
or the privileged true percept of the most threatening object (``--obs privileged``: the
learnability check, the percept of the ``ideal_course`` reference row).

The defaults are chosen to learn within ~30 minutes on 2 CPU cores (``make rl-result``):

- ``--action-repeat 8``: one decision per 8 camera frames (15 Hz at 120 Hz; the detectors still
  see every frame): ~40 decisions per episode instead of ~300;
- ``--dodge-hold-s 0.6``: a dodge (or stop) is one decision held for 0.6 s, the escape controller's
  manoeuvre: one decision, one outcome (random exploration almost never holds a dodge for the ~5
  decisions an evasion needs);
- ``--timely-dodge-bonus 5`` with ``--timely-dodge-window-s 0.5``: the reward credits a dodge that
  comes in time (in the last 0.5 s before the threat's escape deadline) at the decision, not only
  ~1 s later through the avoided collision;
- ``--unnecessary-dodge-per-s 10`` and ``--unnecessary-dodge-penalty 5``: a dodge without a threat
  costs 6 on the decision that dodges, plus 5 once (a 0.6 s dodge from nothing: 11, about a
  collision), instead of one penalty that, once paid, makes every later dodge of the episode free
  (the trap of the first RL result); ``--collision-penalty 10``;
- ``--ent-coef 0.05``, ``--learning-rate 1e-3``, ``--cruise-bias 2``: exploration that lasts until
  the policy has seen which dodges pay (without the entropy bonus the pilot runs collapsed to
  "never dodge" within 10-20 k decisions);
- ``--curriculum-steps N`` (default 0, off): the first N steps on an easier version of the scenario
  (``curriculum_toml``: balls 1.25× larger and 0.6× as fast, so they loom earlier and slower).

Same ``--seed`` → same episodes, same initial weights, same updates: same weights and curve (the
native environments are deterministic under a seed; torch runs on one thread).

Every ``--eval-every`` steps the policy is evaluated on held-out scenario seeds (``--eval-seeds``:
the env's scenario expanded with those seeds, which training,
drawing fresh random expansions from its own seed stream, does not use) and a checkpoint is written.
Everything goes to ``--out``:

- ``config.json``: the arguments; ``progress.csv``: one row per evaluation (steps, wall time, the
  policy's collision, unnecessary-dodge and hit rates, training decisions (environment steps) per second);
- ``checkpoints/step_<N>.zip`` (PPO) or ``.npz`` (CEM) and ``checkpoints/latest.json``;
- ``sb3/``: Stable-Baselines3's CSV and TensorBoard logs (``tensorboard --logdir OUT/sb3``).

A run folder is never overwritten: ``--resume`` continues from its latest checkpoint up to
``--timesteps``. ``loomlab.evaluate`` (or ``make rl-table``) then compares the trained policy
with the threshold controllers and the reference rows on held-out seeds.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
from typing import Any, Dict, List, Optional, Sequence

import numpy as np

from .evaluation import _run_episode, policy_function

ENV_ACTION_TYPES = ("continuous", "discrete", "manoeuvre")
"""``--env`` → the environment's ``action_type`` (``manoeuvre``: the escape controller's manoeuvres,
``loomlab/EscapeDiscrete-v0``'s actions)."""
PROGRESS_FIELDS = [
    "steps",
    "wall_s",
    "episodes",
    "collision_rate",
    "unnecessary_dodge_rate",
    "hit_rate",
    "train_steps_per_s",
]


def parse_seeds(text: str) -> List[int]:
    """``"1000-1003,2000"`` → ``[1000, 1001, 1002, 1003, 2000]`` (at most 10,000 seeds)."""
    seeds: List[int] = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        try:
            if "-" in part:
                a, b = (int(x) for x in part.split("-", 1))
                if b < a:
                    raise ValueError
                seeds.extend(range(a, b + 1))
            else:
                seeds.append(int(part))
        except ValueError:
            raise SystemExit(f"--eval-seeds: `{part}` is not a seed or a range a-b (a <= b), e.g. 1000-1003") from None
        if len(seeds) > 10_000:
            raise SystemExit("--eval-seeds: more than 10,000 seeds; give fewer")
    if not seeds or any(s < 0 for s in seeds):
        raise SystemExit(f"--eval-seeds: `{text}` gives no seed (or a negative one); e.g. 1000-1003")
    return seeds


OBS_MODES = {"detectors": "normalized", "privileged": "privileged", "decision": "decision"}
"""``--obs`` → the environment's ``obs_mode``."""

CURRICULUM_RADIUS_SCALE = 1.25
CURRICULUM_SPEED_SCALE = 0.6


def curriculum_toml(base: str) -> str:
    """An easier version of a scenario's TOML text: every projectile's ``radius_m`` ×1.25 and
    ``speed_mps`` (fixed values and ``[random]`` ranges) ×0.6, so that balls loom earlier and
    slower. Raises ``SystemExit`` naming the fix when the scenario has no projectile."""
    import re

    n = 0

    def scale(m: "re.Match[str]", k: float) -> str:
        nonlocal n
        n += 1
        return f"{m.group(1)}{float(m.group(2)) * k:g}"

    text = re.sub(r"(?m)^(radius_m\s*=\s*)([0-9.]+)", lambda m: scale(m, CURRICULUM_RADIUS_SCALE), base)
    text = re.sub(r"(?m)^(speed_mps\s*=\s*)([0-9.]+)", lambda m: scale(m, CURRICULUM_SPEED_SCALE), text)
    text = re.sub(
        r'("world\.projectiles\.\d+\.speed_mps"\s*=\s*\{\s*min\s*=\s*)([0-9.]+)(\s*,\s*max\s*=\s*)([0-9.]+)',
        lambda m: (
            f"{m.group(1)}{float(m.group(2)) * CURRICULUM_SPEED_SCALE:g}{m.group(3)}"
            f"{float(m.group(4)) * CURRICULUM_SPEED_SCALE:g}"
        ),
        text,
    )
    if n == 0:
        raise SystemExit(
            "--curriculum-steps: the scenario has no projectile `radius_m` / `speed_mps` to make easier; "
            "pass --curriculum-steps 0"
        )
    return text


def _reward(args: argparse.Namespace) -> Dict[str, float]:
    return {
        "collision_penalty": args.collision_penalty,
        "unnecessary_dodge_penalty": args.unnecessary_dodge_penalty,
        "timely_dodge_bonus": args.timely_dodge_bonus,
        "timely_dodge_window_s": args.timely_dodge_window_s,
        "unnecessary_dodge_per_s": args.unnecessary_dodge_per_s,
    }


def make_vec_env(args: argparse.Namespace, curriculum: bool = False):
    """The native vector environment the policy trains on (``curriculum``: on the easier scenario)."""
    from . import scenario_toml
    from .vector import EscapeVectorEnv

    toml = None
    if curriculum:
        if args.scenario is None:
            base = scenario_toml("escape_default")
        elif os.path.exists(args.scenario):
            with open(args.scenario) as f:
                base = f.read()
        else:
            base = scenario_toml(args.scenario)
        toml = curriculum_toml(base)
    return EscapeVectorEnv(
        args.n_envs,
        None if toml is not None else args.scenario,
        scenario_toml=toml,
        frame_size=args.frame_size,
        action_type=args.env,
        obs_mode=OBS_MODES[args.obs],
        action_repeat=args.action_repeat,
        dodge_hold_s=args.dodge_hold_s,
        max_episode_steps=args.max_episode_steps,
        reward=_reward(args),
        tiers=args.tiers,
        seed_stream="train",
    )


def quick_eval(policy: Any, args: argparse.Namespace) -> Dict[str, float]:
    """The policy on the held-out episodes (no runner: the environment's own scoring of the agent)."""
    from . import _native
    from .env import build_options, options_json

    act = policy_function(policy)
    opts = options_json(
        build_options(
            frame_size=args.frame_size,
            action_type=args.env,
            obs_mode=OBS_MODES[args.obs],
            action_repeat=args.action_repeat,
            dodge_hold_s=args.dodge_hold_s,
            max_episode_steps=args.max_episode_steps,
        )
    )
    rows = []
    for seed in args.eval_seeds:
        native = _native.EscapeEnv.from_suite(args.scenario, seed, args.eval_limit, opts)
        try:
            for i in range(0, native.num_episodes, args.eval_stride):
                rows.append(_run_episode(native, i, act, args.env != "continuous"))
        finally:
            native.close()
    n = len(rows)
    threats = [r for r in rows if r["threat"]]
    safe = [r for r in rows if not r["threat"]]
    evadable = [r for r in threats if r["outcome"] in ("hit", "miss")]
    return {
        "episodes": n,
        "collision_rate": sum(r["collision"] for r in rows) / n,
        "unnecessary_dodge_rate": (sum(r["outcome"] == "false_alarm" for r in safe) / len(safe))
        if safe
        else float("nan"),
        "hit_rate": (sum(r["outcome"] == "hit" for r in evadable) / len(evadable)) if evadable else float("nan"),
    }


class Progress:
    """A progress bar (tqdm when installed, else a line every 5 %)."""

    def __init__(self, total: int, initial: int) -> None:
        self.total, self.n, self._last = total, initial, -1
        try:
            from tqdm import tqdm

            self._bar: Any = tqdm(total=total, initial=initial, unit="step", dynamic_ncols=True)
        except ImportError:
            self._bar = None

    def update(self, n: int) -> None:
        self.n += n
        if self._bar is not None:
            self._bar.update(n)
            return
        pct = int(100 * self.n / max(self.total, 1)) // 5 * 5
        if pct != self._last:
            self._last = pct
            print(f"train: {self.n}/{self.total} steps ({pct} %)", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


# --- Stable-Baselines3 -------------------------------------------------------------------------
def sb3_vec_env(venv: Any) -> Any:
    """The native vector environment as a Stable-Baselines3 ``VecEnv`` (same-step auto-reset: an
    environment whose episode ended is reset at once with ``reset_envs``; its last observation is
    ``info["terminal_observation"]``, as SB3 expects)."""
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv

    class LoomlabVecEnv(VecEnv):
        def __init__(self) -> None:
            self.venv = venv
            super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
            self._seed: Optional[int] = None
            self._actions: Any = None

        def reset(self) -> Any:
            obs, _ = self.venv.reset(seed=self._seed)
            self._seed = None
            self.reset_infos = [{} for _ in range(self.num_envs)]
            return obs

        def step_async(self, actions: Any) -> None:
            self._actions = actions

        def step_wait(self) -> Any:
            if self.venv.trains_fast:
                # one native call: step, same-step auto-reset, flat arrays (EscapeVectorEnv.step_train)
                obs, rew, term, trunc, last, _ = self.venv.step_train(self._actions)
                done = np.logical_or(term, trunc)
                infos = [{} for _ in range(self.num_envs)]
                for i in np.flatnonzero(done):
                    infos[i]["terminal_observation"] = last[i]
                    infos[i]["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
                return obs, rew, done, infos
            obs, rew, term, trunc, _ = self.venv.step(self._actions)
            done = np.logical_or(term, trunc)
            infos: List[Dict[str, Any]] = [{} for _ in range(self.num_envs)]
            if done.any():
                idx = np.flatnonzero(done)
                fresh, _ = self.venv.reset_envs(idx)
                obs = np.array(obs, copy=True)
                for k, i in enumerate(idx):
                    infos[i]["terminal_observation"] = obs[i].copy()
                    infos[i]["TimeLimit.truncated"] = bool(trunc[i] and not term[i])
                    obs[i] = fresh[k]
            return obs, np.asarray(rew, dtype=np.float32), done, infos

        def seed(self, seed: Optional[int] = None) -> Sequence[Optional[int]]:
            self._seed = seed
            return [None if seed is None else seed + i for i in range(self.num_envs)]

        def close(self) -> None:
            self.venv.close()

        def get_attr(self, attr_name: str, indices: Any = None) -> List[Any]:
            return [getattr(self.venv, attr_name)] * len(self._get_indices(indices))

        def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
            raise AttributeError(f"set_attr({attr_name!r}) is not supported by the native vector environment")

        def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> List[Any]:
            raise AttributeError(f"env_method({method_name!r}) is not supported by the native vector environment")

        def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> List[bool]:
            return [False] * len(self._get_indices(indices))

    return LoomlabVecEnv()


def _ppo(args: argparse.Namespace, vec: Any, resume_from: Optional[str]) -> Any:
    try:
        import torch
        from stable_baselines3 import PPO
        from stable_baselines3.common.logger import configure
    except ImportError as e:
        raise SystemExit(
            f"--algo ppo needs stable-baselines3 and torch ({e}): pip install 'loomlab[rl]' "
            "(or use --algo cem, pure numpy)"
        ) from e
    torch.set_num_threads(max(1, args.torch_threads))
    formats = ["csv"]
    try:
        import tensorboard  # noqa: F401

        formats.append("tensorboard")
    except ImportError:
        print("train: tensorboard not installed: CSV logs only", file=sys.stderr)
    logger = configure(os.path.join(args.out, "sb3"), formats)
    if resume_from:
        model = PPO.load(resume_from, env=vec, device="cpu")
    else:
        model = PPO(
            "MlpPolicy",
            vec,
            n_steps=args.n_steps,
            batch_size=args.batch_size,
            n_epochs=args.n_epochs,
            learning_rate=args.learning_rate,
            gamma=args.gamma,
            gae_lambda=0.95,
            ent_coef=args.ent_coef,
            policy_kwargs={"net_arch": [args.hidden, args.hidden]},
            seed=args.seed,
            device="cpu",
            verbose=0,
        )
        if args.env != "continuous" and args.cruise_bias:
            # start from a policy that mostly cruises: a random policy departs from cruising on almost
            # every step, so every episode without a threat pays the false-alarm penalty whatever the
            # policy does later, and no single action gets the credit for not dodging
            with torch.no_grad():
                model.policy.action_net.bias[0] += args.cruise_bias
    model.set_logger(logger)
    return model


class _Sb3Learner:
    def __init__(self, args: argparse.Namespace, resume_from: Optional[str], steps: int) -> None:
        self.args = args
        self.curriculum = steps < args.curriculum_steps
        self.vec = sb3_vec_env(make_vec_env(args, self.curriculum))
        self.vec.seed(args.seed if resume_from is None else None)
        self.model = _ppo(args, self.vec, resume_from)
        self.first = resume_from is None

    def learn(self, steps: int, bar: Progress) -> int:
        from stable_baselines3.common.callbacks import BaseCallback

        if self.curriculum and self.model.num_timesteps >= self.args.curriculum_steps:
            # the curriculum is over: the same policy goes on on the scenario itself
            self.curriculum = False
            self.vec.close()
            self.vec = sb3_vec_env(make_vec_env(self.args))
            self.vec.seed(self.args.seed + 1)
            self.model.set_env(self.vec)
        if self.curriculum:
            steps = min(steps, self.args.curriculum_steps - self.model.num_timesteps)
        n = self.vec.num_envs

        class Tick(BaseCallback):
            def _on_step(self) -> bool:
                bar.update(n)
                return True

        before = self.model.num_timesteps
        self.model.learn(steps, callback=Tick(), reset_num_timesteps=self.first, progress_bar=False)
        self.first = False
        return self.model.num_timesteps - before

    @property
    def policy(self) -> Any:
        return self.model

    def save(self, path: str) -> str:
        self.model.save(path)
        return path + ".zip"

    def close(self) -> None:
        self.vec.close()


# --- pure-numpy cross-entropy method -------------------------------------------------------------
class _CemLearner:
    """Cross-entropy method over a linear policy: discrete ``argmax(W·obs + b)``, continuous
    ``tanh(W·obs + b)``; each generation samples one parameter vector per environment, runs one
    episode with each and refits the sampling distribution to the best ``elite`` fraction."""

    def __init__(self, args: argparse.Namespace, resume_from: Optional[str], steps: int) -> None:
        self.args = args
        self.steps = steps
        self.curriculum = steps < args.curriculum_steps
        self.venv = make_vec_env(args, self.curriculum)
        self.discrete = args.env != "continuous"
        self.obs_dim = int(self.venv.single_observation_space.shape[0])
        self.out_dim = int(self.venv.single_action_space.n) if self.discrete else 3
        size = (self.obs_dim + 1) * self.out_dim
        self.mean = np.zeros(size)
        self.std = np.full(size, 0.5)
        self.rng = np.random.default_rng(args.seed)
        self.env_seed: Optional[int] = args.seed
        self.elite = 0.25
        if resume_from:
            z = np.load(resume_from)
            self.mean, self.std = z["mean"], z["std"]
            self.rng.bit_generator.state = json.loads(str(z["rng"]))
            self.env_seed = None

    def _act(self, theta: np.ndarray, obs: np.ndarray) -> Any:
        w = theta.reshape(self.obs_dim + 1, self.out_dim)
        z = obs @ w[:-1] + w[-1]
        return int(np.argmax(z)) if self.discrete else np.tanh(z).astype(np.float32)

    def learn(self, steps: int, bar: Progress) -> int:
        done_steps = 0
        n = self.venv.num_envs
        while done_steps < steps:
            if self.curriculum and self.steps + done_steps >= self.args.curriculum_steps:
                # the curriculum is over: the same search goes on on the scenario itself
                self.curriculum = False
                self.venv.close()
                self.venv = make_vec_env(self.args)
                self.env_seed = self.args.seed + 1
            thetas = self.mean + self.std * self.rng.standard_normal((n, self.mean.size))
            obs, _ = self.venv.reset(seed=self.env_seed)
            self.env_seed = None
            returns = np.zeros(n)
            alive = np.ones(n, dtype=bool)
            while alive.any():
                acts = [self._act(thetas[i], obs[i]) for i in range(n)]
                actions = np.asarray(acts, dtype=np.int64) if self.discrete else np.stack(acts)
                obs, rew, term, trunc, _ = self.venv.step(actions)
                returns += np.where(alive, rew, 0.0)
                done_steps += int(alive.sum())
                bar.update(int(alive.sum()))
                alive &= ~np.logical_or(term, trunc)
            k = max(1, int(round(self.elite * n)))
            best = thetas[np.argsort(returns)[-k:]]
            self.mean = best.mean(axis=0)
            self.std = best.std(axis=0) + 0.02
        self.steps += done_steps
        return done_steps

    @property
    def policy(self) -> Any:
        theta = self.mean.copy()
        return lambda obs, info: self._act(theta, np.asarray(obs))

    def save(self, path: str) -> str:
        np.savez(path + ".npz", mean=self.mean, std=self.std, rng=json.dumps(self.rng.bit_generator.state))
        return path + ".npz"

    def close(self) -> None:
        self.venv.close()


# --- the training loop -----------------------------------------------------------------------------
def _latest(out: str) -> Optional[Dict[str, Any]]:
    p = os.path.join(out, "checkpoints", "latest.json")
    if not os.path.exists(p):
        return None
    with open(p) as f:
        return json.load(f)


def train(args: argparse.Namespace) -> Dict[str, Any]:
    """Trains as ``python -m loomlab.train`` does; returns the last evaluation row."""
    config_path = os.path.join(args.out, "config.json")
    latest = None
    if args.resume:
        latest = _latest(args.out)
        if latest is None:
            raise SystemExit(
                f"--resume: {args.out} has no checkpoint (checkpoints/latest.json); start without --resume"
            )
        with open(config_path) as f:
            saved = json.load(f)
        for key in ("env", "algo", "seed", "n_envs", "frame_size", "scenario", "obs", "action_repeat", "dodge_hold_s"):
            if saved.get(key) != getattr(args, key):
                raise SystemExit(
                    f"--resume: --{key.replace('_', '-')} {getattr(args, key)!r} differs from the run's "
                    f"{saved.get(key)!r} (in {config_path}); resume with the same settings"
                )
    elif os.path.exists(config_path):
        raise SystemExit(
            f"{args.out} already holds a run (config.json): pass --resume to continue it, or another --out"
        )
    os.makedirs(os.path.join(args.out, "checkpoints"), exist_ok=True)
    if not args.resume:
        with open(config_path, "w") as f:
            json.dump({k: v for k, v in vars(args).items() if k != "resume"}, f, indent=2)
    steps = latest["steps"] if latest else 0
    learner: Any = (_Sb3Learner if args.algo == "ppo" else _CemLearner)(args, latest and latest["path"], steps)
    wall0 = latest["wall_s"] if latest else 0.0
    started = time.monotonic()
    progress_path = os.path.join(args.out, "progress.csv")
    new_file = not os.path.exists(progress_path)
    bar = Progress(args.timesteps, steps)
    row: Dict[str, Any] = {}
    try:
        with open(progress_path, "a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=PROGRESS_FIELDS)
            if new_file:
                w.writeheader()
            if steps == 0:
                row = _eval_row(learner, args, 0, 0.0, float("nan"))
                w.writerow(row)
                f.flush()
            while steps < args.timesteps:
                chunk = min(args.eval_every, args.timesteps - steps)
                t0 = time.monotonic()
                done = learner.learn(chunk, bar)
                steps += done
                rate = done / max(time.monotonic() - t0, 1e-9)
                wall = wall0 + time.monotonic() - started
                path = learner.save(os.path.join(args.out, "checkpoints", f"step_{steps}"))
                with open(os.path.join(args.out, "checkpoints", "latest.json"), "w") as lf:
                    json.dump({"steps": steps, "wall_s": wall, "path": path}, lf)
                row = _eval_row(learner, args, steps, wall, rate)
                w.writerow(row)
                f.flush()
                if args.max_wall_s is not None and wall >= args.max_wall_s:
                    print(
                        f"\ntrain: stopping at {steps} steps: --max-wall-s {args.max_wall_s} reached", file=sys.stderr
                    )
                    break
                print(
                    f"\ntrain: {steps} steps, {wall:.0f} s: held-out collision rate {row['collision_rate']:.3f}, "
                    f"unnecessary-dodge rate {row['unnecessary_dodge_rate']:.3f}, {rate:.0f} steps/s",
                    file=sys.stderr,
                    flush=True,
                )
    finally:
        bar.close()
        learner.close()
    return row


def _eval_row(learner: Any, args: argparse.Namespace, steps: int, wall: float, rate: float) -> Dict[str, Any]:
    r = quick_eval(learner.policy, args)
    return {
        "steps": steps,
        "wall_s": round(wall, 1),
        "episodes": r["episodes"],
        "collision_rate": r["collision_rate"],
        "unnecessary_dodge_rate": r["unnecessary_dodge_rate"],
        "hit_rate": r["hit_rate"],
        "train_steps_per_s": round(rate, 1),
    }


def plot_progress(run_dirs: Sequence[str], png: str, report: Optional[str] = None) -> None:
    """Draws the learning curves (held-out collision and unnecessary-dodge rates over training steps)
    of one or more runs into ``png``; with ``report`` (``python -m loomlab.evaluation --out``), the
    threshold controllers' and the reference rows' rates on the held-out evaluation as lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
    keys = [("collision_rate", "collision rate"), ("unnecessary_dodge_rate", "unnecessary-dodge rate")]
    for run in run_dirs:
        with open(os.path.join(run, "progress.csv")) as f:
            rows = list(csv.DictReader(f))
        steps = [int(r["steps"]) for r in rows]
        for ax, (key, _) in zip(axes, keys):
            ax.plot(steps, [float(r[key]) for r in rows], marker="o", ms=3, label=os.path.basename(run.rstrip("/")))
    if report:
        with open(report) as f:
            rep = json.load(f)
        dets = rep["detectors"]
        refs = set(rep.get("references", [])) | {rep.get("policy_label")}
        baselines = [k for k in dets if k not in refs and k != "hopfield" and dets[k].get("collision_rate") is not None]
        best = min(baselines, key=lambda k: dets[k]["collision_rate"], default=None)
        shown = [("null", "black"), ("oracle", "green"), ("hopfield", "tab:red"), (best, "tab:purple")]
        for label, color in shown:
            if label not in dets:
                continue
            for ax, (key, _) in zip(axes, keys):
                v = dets[label].get("false_alarm_rate" if key == "unnecessary_dodge_rate" else key)
                if v is not None:
                    ax.axhline(v, ls="--", lw=1, color=color, label=f"{label} (held-out evaluation)")
    for ax, (_, title) in zip(axes, keys):
        ax.set_xlabel("environment steps")
        ax.set_ylabel(f"held-out {title}")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=120)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m loomlab.train",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--env",
        choices=ENV_ACTION_TYPES,
        default="discrete",
        help="action space (default: discrete; manoeuvre: cruise, sidesteps, stop, reverse, plan)",
    )
    p.add_argument(
        "--obs",
        choices=sorted(OBS_MODES),
        default="detectors",
        help="detectors: the normalized detector features (default); privileged: the true percept of the most "
        "threatening object (the learnability check; ground truth, like the ideal rows)",
    )
    p.add_argument(
        "--action-repeat",
        type=int,
        default=8,
        help="camera frames per decision (default 8: 15 Hz at 120 Hz; 1: every frame)",
    )
    p.add_argument(
        "--dodge-hold-s",
        type=float,
        default=0.6,
        help="a discrete dodge or stop is one decision held this long (s; default 0.6, the escape manoeuvre; "
        "0: --action-repeat frames like every action)",
    )
    p.add_argument(
        "--timely-dodge-bonus",
        type=float,
        default=5.0,
        help="reward.timely_dodge_bonus: once for a dodge in the window before the escape deadline (default 5)",
    )
    p.add_argument(
        "--timely-dodge-window-s",
        type=float,
        default=0.5,
        help="reward.timely_dodge_window_s: the bonus window before the escape deadline (s; default 0.5)",
    )
    p.add_argument(
        "--unnecessary-dodge-per-s",
        type=float,
        default=10.0,
        help="reward.unnecessary_dodge_per_s: cost per second of dodging without a threat (default 10: "
        "6 for a 0.6 s dodge, charged on the decision that dodges)",
    )
    p.add_argument(
        "--curriculum-steps",
        type=int,
        default=0,
        help="train the first N steps on the easier scenario (balls 1.25x larger, 0.6x as fast; default 0: off)",
    )
    p.add_argument("--hidden", type=int, default=64, help="units of each of the policy's 2 hidden layers (default 64)")
    p.add_argument("--algo", choices=["ppo", "cem"], default="ppo", help="ppo (stable-baselines3) or cem (numpy)")
    p.add_argument(
        "--timesteps", type=int, default=200_000, help="decisions (environment steps) in total (default 200000)"
    )
    p.add_argument("--n-envs", type=int, default=8, help="environments of the native vector env (default 8)")
    p.add_argument("--seed", type=int, default=0, help="seed of the policy and the training episodes (default 0)")
    p.add_argument("--out", default=None, help="run folder (default out/train/<env>-<algo>-seed<seed>)")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its latest checkpoint")
    p.add_argument(
        "--scenario",
        default=None,
        help="scenario name, TOML path or suite (a folder, list file or suite:NAME; default: escape_default)",
    )
    p.add_argument(
        "--tiers",
        type=lambda t: [int(x) for x in t.split(",") if x.strip()],
        default=None,
        help="suites: train on the scenarios of these tiers only, e.g. 0,1 (default: all)",
    )
    p.add_argument("--frame-size", type=int, default=64, help="camera frame size n (default 64)")
    p.add_argument(
        "--max-wall-s", type=float, default=None, help="stop after the evaluation past this wall time (s; total)"
    )
    p.add_argument("--max-episode-steps", type=int, default=None, help="truncate episodes (default: none)")
    p.add_argument(
        "--eval-every", type=int, default=8192, help="steps between evaluations + checkpoints (default 8192)"
    )
    p.add_argument(
        "--eval-seeds", type=parse_seeds, default="1000-1003", help="held-out scenario seeds (default 1000-1003)"
    )
    p.add_argument("--eval-limit", type=int, default=None, help="episodes per held-out seed (default: all)")
    p.add_argument(
        "--eval-stride",
        type=int,
        default=1,
        help="evaluate every K-th episode of each held-out expansion (a suite's scenarios in turn; default 1: all)",
    )
    p.add_argument("--collision-penalty", type=float, default=10.0, help="reward.collision_penalty (default 10)")
    p.add_argument(
        "--unnecessary-dodge-penalty",
        type=float,
        default=5.0,
        help="reward.unnecessary_dodge_penalty: once per false alarm (default 5; with the per-second cost a "
        "0.6 s dodge from nothing costs 11, about a collision)",
    )
    p.add_argument("--n-steps", type=int, default=128, help="PPO rollout length per environment (default 128)")
    p.add_argument("--batch-size", type=int, default=256, help="PPO minibatch size (default 256)")
    p.add_argument("--n-epochs", type=int, default=10, help="PPO epochs per rollout (default 10)")
    p.add_argument("--learning-rate", type=float, default=1e-3, help="PPO learning rate (default 1e-3)")
    p.add_argument(
        "--gamma",
        type=float,
        default=0.98,
        help="discount (default 0.98: episodes are ~40 decisions at --action-repeat 8)",
    )
    p.add_argument("--ent-coef", type=float, default=0.05, help="PPO entropy bonus (default 0.05)")
    p.add_argument(
        "--cruise-bias",
        type=float,
        default=2.0,
        help="discrete PPO: initial logit bonus of action 0 (cruise); 2 gives a ~29 %% chance per decision of "
        "departing from cruising at the start (default 2; 0: a uniform initial policy)",
    )
    p.add_argument(
        "--plot",
        nargs="+",
        metavar="RUN",
        default=None,
        help="do not train: draw the learning curves of these run folders into --plot-out",
    )
    p.add_argument("--plot-out", default="docs/rl_learning_curve.png", help="PNG of --plot")
    p.add_argument("--plot-report", default=None, help="with --plot: an evaluation report whose rows to draw as lines")
    p.add_argument("--torch-threads", type=int, default=1, help="torch CPU threads (default 1)")
    return p


def main(argv: Optional[Sequence[str]] = None) -> None:
    args = parser().parse_args(argv)
    if args.plot:
        plot_progress(args.plot, args.plot_out, args.plot_report)
        print(f"wrote {args.plot_out}")
        return
    for key in (
        "timesteps",
        "n_envs",
        "eval_every",
        "eval_stride",
        "n_steps",
        "batch_size",
        "n_epochs",
        "action_repeat",
        "hidden",
    ):
        if getattr(args, key) < 1:
            raise SystemExit(f"--{key.replace('_', '-')} must be >= 1, got {getattr(args, key)}")
    if args.n_envs > 256:
        raise SystemExit(f"--n-envs must be <= 256, got {args.n_envs}")
    if args.scenario is not None and args.scenario.startswith("suite:"):
        from .env import suite_path

        # the folder itself: the held-out evaluation (EscapeEnv.from_suite) expands it as loomlab run does
        args.scenario = suite_path(args.scenario[len("suite:") :])
    if args.out is None:
        args.out = os.path.join("out", "train", f"{args.env}-{args.algo}-seed{args.seed}")
    row = train(args)
    print(json.dumps(row))


if __name__ == "__main__":
    main()
