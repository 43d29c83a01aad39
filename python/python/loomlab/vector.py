"""`EscapeVectorEnv`: N environments stepped on Rust threads, returning batched numpy arrays.

It wraps the native class of the same name, ``loomlab._native.EscapeVectorEnv`` (Rust
``loomlab_env::EscapeVectorEnv``).

``gymnasium.make_vec("loomlab/Escape-v0", num_envs=N)`` builds it. Auto-reset is Gymnasium's
``NEXT_STEP`` mode (the default of ``SyncVectorEnv``): the step after an environment's episode ended
resets it, ignoring its action, and reports reward 0 and ``terminated = truncated = False``; so the
results equal those of N :class:`~loomlab.EscapeEnv` in a ``SyncVectorEnv`` with the same seeds.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Mapping, Optional, Sequence, Union

import numpy as np
from gymnasium.error import ClosedEnvironmentError
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from . import _native
from ._native import ActionError, ScenarioError
from .env import (
    _OPEN,
    ActionConfig,
    RewardConfig,
    _constructor_kwargs,
    _native_options,
    _real_array,
    _seed_arg,
    make_spaces,
)

__all__ = ["EscapeVectorEnv"]


class EscapeVectorEnv(VectorEnv):
    """``num_envs`` copies of :class:`~loomlab.EscapeEnv` (same arguments) stepped in parallel in Rust.

    ``reset(seed=s)`` seeds environment i with ``s + i``. ``step(actions)`` takes a ``(num_envs, 3)``
    float array (continuous) or a ``(num_envs,)`` integer array (discrete). Observations are dicts of
    ``(num_envs, …)`` arrays; ``info`` follows Gymnasium's vector convention (arrays plus ``_key``
    masks), with ``info["outcome"]`` for the environments whose episode just ended. An error of one
    environment names its index (``environment 2 of the vector environment: …``).

    It pickles like :class:`~loomlab.EscapeEnv`: the constructor arguments plus every environment's
    seed stream and actions, replayed on unpickling, so the copy continues exactly as the original.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 120, "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        num_envs: int = 1,
        scenario: Union[str, os.PathLike, Sequence[str], None] = None,
        *,
        scenario_toml: Optional[str] = None,
        detectors: Union[str, Sequence[str], None] = None,
        thresholds: Optional[Mapping[str, float]] = None,
        frame_size: Optional[int] = 64,
        observe_frames: bool = False,
        action_type: str = "continuous",
        action_config: Union[ActionConfig, Mapping[str, float], None] = None,
        clip_actions: bool = False,
        reward: Union[RewardConfig, Mapping[str, float], None] = None,
        max_episode_steps: Optional[int] = None,
        obs_mode: str = "raw",
        action_repeat: int = 1,
        dodge_hold_s: float = 0.0,
        sensor: Optional[str] = None,
        tiers: Optional[Sequence[int]] = None,
        seed_stream: Optional[str] = None,
        render_mode: Optional[str] = None,
    ) -> None:
        if not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ScenarioError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self._kwargs: Dict[str, Any] = dict(
            num_envs=int(num_envs),
            **_constructor_kwargs(
                scenario=scenario,
                scenario_toml=scenario_toml,
                detectors=detectors,
                thresholds=thresholds,
                frame_size=frame_size,
                observe_frames=observe_frames,
                action_type=action_type,
                action_config=action_config,
                clip_actions=clip_actions,
                reward=reward,
                max_episode_steps=max_episode_steps,
                obs_mode=obs_mode,
                action_repeat=action_repeat,
                dodge_hold_s=dodge_hold_s,
                sensor=sensor,
                tiers=tiers,
                seed_stream=seed_stream,
                render_mode=render_mode,
            ),
        )
        self._native = _native.EscapeVectorEnv(
            int(num_envs), self._kwargs["scenario"], scenario_toml, _native_options(self._kwargs)
        )
        _OPEN.add(self)
        self.num_envs = int(num_envs)
        self.single_observation_space, self.single_action_space = make_spaces(self._native)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=int(round(1.0 / self._native.dt)))
        self._discrete = self._native.action_kind in ("discrete", "manoeuvre")
        # a feature vector without frames: one array (the native side batches it as a dict)
        vector_obs = self._native.obs_mode in ("normalized", "privileged", "decision")
        self._flat = vector_obs and not self._native.observe_frames

    @property
    def detector_ids(self) -> list:
        """Chosen detector ids (``hopfield``, ``soc``, …), in the order of ``alarm``."""
        return list(self._native.detector_ids)

    @property
    def detector_labels(self) -> list:
        """Chosen detectors' labels: the per-detector observation keys, in the order of ``alarm``."""
        return list(self._native.detector_labels)

    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None):
        """Resets every environment.

        Args:
            seed: environment i gets ``seed + i``, which must lie in [0, 2**64); ``None``: each
                environment continues its seed stream.
            options: not supported (must be empty).

        Returns:
            ``(observations, infos)``, batched.

        Raises:
            ValueError: ``seed`` (or ``seed + num_envs - 1``) is not an integer in [0, 2**64).
            gymnasium.error.ClosedEnvironmentError: the environment was closed.
        """
        seed = _seed_arg(seed, self.num_envs)
        self._check_open("reset()")
        super().reset(seed=seed)
        if options:
            raise ScenarioError(f"reset() takes no options, got {sorted(options)}")
        obs, info = self._native.reset(seed)
        return self._obs(obs), self._merge_outcomes(info)

    def step(self, actions: Any):
        """Steps every environment (those whose episode ended in the last step are reset instead).

        Returns:
            ``(observations, rewards, terminations, truncations, infos)``, batched.

        Raises:
            ActionError: the actions are malformed; an error of one environment names its index.
            gymnasium.error.ClosedEnvironmentError: the environment was closed.
        """
        self._check_open("step()")
        if self._discrete:
            a = np.asarray(actions)
            if a.shape != (self.num_envs,) or not (np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_):
                raise ActionError(
                    f"discrete actions must be an integer array of shape ({self.num_envs},), got "
                    f"{a.dtype} array of shape {a.shape}"
                )
            result = self._native.step_discrete(np.ascontiguousarray(a, dtype=np.int64))
        else:
            a = _real_array(actions, f"continuous actions must be a ({self.num_envs}, 3) float array")
            if a.shape != (self.num_envs, 3):
                raise ActionError(
                    f"continuous actions must have shape ({self.num_envs}, 3) [forward, yaw_rate, lateral], "
                    f"got shape {a.shape}"
                )
            result = self._native.step_continuous(np.ascontiguousarray(a))
        obs, reward, terminated, truncated, info = result
        return self._obs(obs), reward, terminated, truncated, self._merge_outcomes(info)

    @property
    def trains_fast(self) -> bool:
        """Whether :meth:`step_train` is available: one feature vector per observation (obs_mode
        ``normalized``, ``privileged`` or ``decision``) and no frames."""
        return bool(self._flat)

    def step_train(self, actions: Any):
        """The training step: :meth:`step` with **same-step** auto-reset in one native call, flat
        arrays only (no info dicts): what a training loop needs per decision.

        Returns:
            ``(observations, rewards, terminations, truncations, final_observations, outcomes)``: the
            next observations ``(num_envs, F)`` float32 (the new episode's first one where an episode
            ended), float32 rewards, the flags, the observations the step ended on (an ended
            episode's last one; the others equal ``observations``) and ``[(index, outcome)]`` of the
            episodes that ended (``info["outcome"]`` of :meth:`step`).

        Raises:
            ActionError: the actions are malformed, or the observation is not one feature vector.
        """
        self._check_open("step_train()")
        if self._discrete:
            a = np.asarray(actions)
            if a.shape != (self.num_envs,) or not np.issubdtype(a.dtype, np.integer):
                raise ActionError(
                    f"discrete actions must be an integer array of shape ({self.num_envs},), got "
                    f"{a.dtype} array of shape {a.shape}"
                )
            return self._native.step_train(np.ascontiguousarray(a, dtype=np.int64))
        a = _real_array(actions, f"continuous actions must be a ({self.num_envs}, 3) float array")
        return self._native.step_train(np.ascontiguousarray(a, dtype=np.float32))

    def _obs(self, obs: Dict[str, Any]) -> Any:
        return obs["features"] if self._flat else obs

    def reset_envs(self, indices: Sequence[int]):
        """Resets the environments ``indices`` now (their seed streams continue) and cancels their
        pending next-step auto-reset: ``(observations, infos)`` batched over ``indices`` in that order.
        For same-step auto-reset adapters (Stable-Baselines3's ``VecEnv``, :mod:`loomlab.train`)."""
        self._check_open("reset_envs()")
        obs, info = self._native.reset_envs([int(i) for i in indices])
        info.pop("_outcomes", None)
        return self._obs(obs), info

    def render(self) -> Optional[np.ndarray]:
        """The latest frames as ``(num_envs, n, n, 3)`` uint8 (``render_mode="rgb_array"``)."""
        if self.render_mode != "rgb_array":
            return None
        self._check_open("render()")
        frames = self._native.frames()
        return np.repeat(frames[..., None], 3, axis=3)

    def close_extras(self, **kwargs: Any) -> None:
        """Releases every environment's renderer and episode and joins their background threads
        (``close()`` calls it once; environments still open at interpreter exit are closed then)."""
        self._native.close()
        _OPEN.discard(self)

    def _check_open(self, what: str) -> None:
        if self.closed or self._native.closed:
            raise ClosedEnvironmentError(
                f"{what} called on a closed environment; close() released it, so make a new environment"
            )

    # --- pickling: the constructor arguments plus every environment's seed stream and actions ------
    def __getstate__(self) -> Dict[str, Any]:
        closed = bool(self.closed or self._native.closed)
        return {
            "kwargs": self._kwargs,
            "snapshot": None if closed else self._native.snapshot(),
            "closed": closed,
            "np_random": self._np_random,
            "np_random_seed": self._np_random_seed,
        }

    def __setstate__(self, state: Dict[str, Any]) -> None:
        self.__init__(**state["kwargs"])
        if state.get("closed"):
            self.close()
        else:
            self._native.restore(state["snapshot"])
        self._np_random = state.get("np_random")
        self._np_random_seed = state.get("np_random_seed")

    def _merge_outcomes(self, info: Dict[str, Any]) -> Dict[str, Any]:
        for i, outcome in info.pop("_outcomes"):
            info = self._add_info(info, {"outcome": outcome}, i)
        return info
