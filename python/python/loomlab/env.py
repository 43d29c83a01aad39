"""`EscapeEnv`: a Gymnasium environment over loomlab's closed-loop escape simulator.

The simulation, rendering, detectors, ground truth and scoring run in Rust: this class wraps the
native class of the same name, ``loomlab._native.EscapeEnv`` (Rust ``loomlab_env::EscapeEnv``), and
declares the Gymnasium spaces and converts actions. Defaults and action names come from the native
module (``REWARD_DEFAULTS``, ``ACTION_DEFAULTS``, ``DISCRETE_ACTIONS``, ``CONTINUOUS_ACTION_NAMES``).
See the package README for the observation, action and reward definitions.
"""

from __future__ import annotations

import atexit
import json
import math
import os
import weakref
from dataclasses import asdict, dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ClosedEnvironmentError

from . import _native
from ._native import ActionError, ScenarioError

__all__ = ["EscapeEnv", "RewardConfig", "ActionConfig", "build_options", "make_spaces"]

_OPEN: "weakref.WeakSet[Any]" = weakref.WeakSet()
"""The environments (single and vector) not closed yet: closed at interpreter exit."""


@atexit.register
def _close_open_envs() -> None:
    """Closes every environment still open, which joins its background threads (a thread still
    rendering on lavapipe while the interpreter exits can crash it with a segfault)."""
    for env in list(_OPEN):
        try:
            env.close()
        except Exception:  # pragma: no cover - best effort at exit
            pass


DISCRETE_ACTIONS: Tuple[str, ...] = tuple(_native.DISCRETE_ACTIONS)
"""Names of the discrete actions, by index (Rust ``DiscreteAction::ALL``)."""

CONTINUOUS_ACTION_NAMES: Tuple[str, ...] = tuple(_native.CONTINUOUS_ACTION_NAMES)
"""Names of the continuous action components (each in [-1, 1]; Rust ``ContinuousAction::NAMES``)."""

MANOEUVRE_ACTIONS: Tuple[str, ...] = tuple(_native.MANOEUVRE_ACTIONS)
"""Names of the manoeuvre actions (``action_type="manoeuvre"``), by index: the escape controller's
manoeuvres (Rust ``loomlab_env::MANOEUVRE_ACTIONS``)."""

OBS_MODES: Tuple[str, ...] = tuple(_native.OBS_MODES)
"""Observation modes: ``"raw"`` (detector outputs as they are), ``"normalized"`` (bounded features),
``"privileged"`` (the true percept of the most threatening object: a learnability check) and
``"decision"`` (every row's decision quantities: τ̂, the course gate, the predicted arrival, the
K-of-M count, the alarm, and the tracks' boxes; ``loomlab_env::features``)."""

ACTION_TYPES: Tuple[str, ...] = ("continuous", "discrete", "manoeuvre")
"""Action spaces (``action_type=``)."""

SEED_STREAMS: Tuple[str, ...] = ("train", "eval")
"""Seed streams (``seed_stream=``): disjoint halves of the seeds (the top bit of every drawn seed)."""

DEFAULT_SUITE_ARG = "suite:default"
"""The ``scenario`` of the registered ids: the default suite (``scenarios/suites/default``, the suite
``loomlab run`` runs). ``suite:NAME`` names a suite folder of the repository
(``scenarios/suites/NAME``), found from the checkout the package is built from, the working
directory, or ``$LOOMLAB_SUITES`` (a folder holding the suite folders)."""


def suite_path(name: str) -> str:
    """The folder of suite ``name`` (``"default"``, ``"heldout"``): see :data:`DEFAULT_SUITE_ARG`.

    Raises:
        ScenarioError: no such folder; the message lists where it looked and the fix.
    """
    here = os.path.dirname(os.path.abspath(__file__))
    roots = [os.environ.get("LOOMLAB_SUITES"), os.path.join(here, "..", "..", "..", "scenarios", "suites")]
    roots.append(os.path.join(os.getcwd(), "scenarios", "suites"))
    tried = []
    for root in roots:
        if root:
            path = os.path.normpath(os.path.join(root, name))
            tried.append(path)
            if os.path.isdir(path):
                return path
    raise ScenarioError(
        f"suite `suite:{name}` not found (looked in {', '.join(tried)}); run from the repository root, set "
        "LOOMLAB_SUITES to the folder holding the suite folders, or pass scenario= a suite folder or file"
    )


SENSOR_PROFILES: Tuple[str, ...] = tuple(_native.SENSOR_PROFILES)
"""Camera sensor profiles (``sensor=``): ``"ideal"`` (noiseless, instantaneous) and ``"robot"`` (exposure
blur, shot and read noise, gain, 8-bit quantisation, perception and actuation latency; Rust
``loomlab_sim::SENSOR_PROFILES``, docs/reference.md "Sensor profiles")."""


class SensorProfileError(ScenarioError, ValueError):
    """An unknown ``sensor`` profile name: a :class:`ScenarioError` that is also a ``ValueError``."""


_REWARD = _native.REWARD_DEFAULTS
_ACTION = _native.ACTION_DEFAULTS


@dataclass
class RewardConfig:
    """Reward weights (all >= 0; the sign of each term is fixed). Per step of length dt:

    ``survival_per_s*dt`` (no collision) ``+ progress_per_m*Δs`` (metres along the start heading)
    ``- effort_per_s*|u - u_cruise|²*dt`` ``- unnecessary_dodge_per_s*dt`` (dodging in an episode
    without a threat) ``- unnecessary_dodge_penalty`` (once, on the first such step: a false alarm)
    ``- collision_penalty`` (once, on contact) ``+ timely_dodge_bonus`` (once, on the first dodging
    step of an episode with an evadable threat in the last ``timely_dodge_window_s`` before its
    escape deadline less the lead margin: an informed hit, credited at the time of the decision).

    The defaults are Rust's ``RewardConfig::default()`` (``loomlab._native.REWARD_DEFAULTS``).
    """

    collision_penalty: float = _REWARD["collision_penalty"]
    survival_per_s: float = _REWARD["survival_per_s"]
    progress_per_m: float = _REWARD["progress_per_m"]
    effort_per_s: float = _REWARD["effort_per_s"]
    unnecessary_dodge_per_s: float = _REWARD["unnecessary_dodge_per_s"]
    unnecessary_dodge_penalty: float = _REWARD["unnecessary_dodge_penalty"]
    timely_dodge_bonus: float = _REWARD["timely_dodge_bonus"]
    timely_dodge_window_s: float = _REWARD["timely_dodge_window_s"]


@dataclass
class ActionConfig:
    """Scales of the action mappings: continuous ±1 = ``max_*``; discrete dodges add ``dodge_speed_mps``
    sideways to the cruise command.

    The defaults are Rust's ``ActionConfig::default()`` (``loomlab._native.ACTION_DEFAULTS``)."""

    dodge_speed_mps: float = _ACTION["dodge_speed_mps"]
    max_forward_mps: float = _ACTION["max_forward_mps"]
    max_yaw_rate_rps: float = _ACTION["max_yaw_rate_rps"]
    max_lateral_mps: float = _ACTION["max_lateral_mps"]


def _as_dict(x: Any) -> Optional[Dict[str, Any]]:
    if x is None:
        return None
    if isinstance(x, Mapping):
        return dict(x)
    return asdict(x)


def _option_error(key: str, value: Any, fix: str) -> ScenarioError:
    """An invalid option, worded as Rust's ``EnvError::InvalidOption``: the key, the value, the fix."""
    return ScenarioError(f"invalid environment option `{key}` = {value!r}: {fix}")


def _bool_option(key: str, value: Any) -> bool:
    """A boolean option: only ``True``/``False`` (``bool`` or ``numpy.bool_``); ``bool('no')`` is true."""
    if not isinstance(value, (bool, np.bool_)):
        raise _option_error(key, value, "must be True or False (a bool; strings and numbers are not read as booleans)")
    return bool(value)


def _json_option(key: str, value: Any) -> Any:
    """An option value as plain JSON data (numpy scalars unwrapped), checked on the way: floats must be
    finite, mapping keys strings. ``key`` is the option's path as the caller wrote it (``reward.effort_per_s``)."""
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            raise _option_error(key, value, "must be a finite number (NaN and infinities are never valid options)")
        return float(value)
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise _option_error(f"{key}[{k!r}]", v, f"keys of `{key}` must be strings, got {type(k).__name__}")
            out[k] = _json_option(f"{key}.{k}", v)
        return out
    if isinstance(value, (list, tuple)):
        return [_json_option(f"{key}[{i}]", v) for i, v in enumerate(value)]
    raise _option_error(key, value, f"expected a real number, string, bool, list or dict, got {type(value).__name__}")


def options_json(options: Mapping[str, Any]) -> str:
    """The JSON text of :func:`build_options`' dict, as the native environments take it."""
    return json.dumps(options, allow_nan=False)


def build_options(
    *,
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
) -> Dict[str, Any]:
    """The options dict passed (as JSON, :func:`options_json`) to the native environment.

    Checked here as far as Python sees them (booleans are bools, numbers real and finite; errors name
    the option as passed, e.g. ``reward.effort_per_s``), then validated in Rust.

    Raises:
        ScenarioError: an option is invalid; the message names the option, the value and the fix.
    """
    if isinstance(detectors, str):
        detectors = [d.strip() for d in detectors.split(",") if d.strip()]
        if detectors == ["all"]:
            detectors = list(_native.detector_ids())
    if action_type not in ACTION_TYPES:
        raise _option_error("action_type", action_type, f"must be one of {', '.join(map(repr, ACTION_TYPES))}")
    if seed_stream is not None and seed_stream not in SEED_STREAMS:
        raise _option_error(
            "seed_stream", seed_stream, "must be 'train', 'eval' (disjoint halves of the seeds) or None (either)"
        )
    if obs_mode not in OBS_MODES:
        raise _option_error("obs_mode", obs_mode, f"must be one of {', '.join(map(repr, OBS_MODES))}")
    opts: Dict[str, Any] = {
        "detectors": _json_option("detectors", list(detectors) if detectors is not None else None),
        "thresholds": _json_option("thresholds", dict(thresholds or {})),
        "frame_size": _json_option("frame_size", frame_size),
        "observe_frames": _bool_option("observe_frames", observe_frames),
        "action_kind": action_type,
        "clip_actions": _bool_option("clip_actions", clip_actions),
        "max_episode_steps": _json_option("max_episode_steps", max_episode_steps),
        "obs_mode": obs_mode,
        "action_repeat": _json_option("action_repeat", action_repeat),
        "dodge_hold_s": _json_option("dodge_hold_s", dodge_hold_s),
        "tiers": _json_option("tiers", list(tiers) if tiers is not None else None),
        "seed_stream": seed_stream,
    }
    if sensor is not None:
        if not isinstance(sensor, str) or sensor not in SENSOR_PROFILES:
            raise SensorProfileError(
                f"invalid environment option `sensor` = {sensor!r}: must be one of "
                f"{', '.join(map(repr, SENSOR_PROFILES))} (or None: the scenario file's own sensor keys)"
            )
        opts["sensor"] = sensor
    if action_config is not None:
        opts["action"] = _json_option("action_config", _as_dict(action_config))
    if reward is not None:
        opts["reward"] = _json_option("reward", _as_dict(reward))
    return opts


def make_spaces(native: Any) -> Tuple[spaces.Space, spaces.Space]:
    """The single-environment observation and action spaces of a native environment."""
    if native.action_kind == "discrete":
        action: spaces.Space = spaces.Discrete(len(DISCRETE_ACTIONS))
    elif native.action_kind == "manoeuvre":
        action = spaces.Discrete(len(MANOEUVRE_ACTIONS))
    else:
        action = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
    if native.obs_mode in ("normalized", "privileged", "decision"):
        features = spaces.Box(
            np.asarray(native.feature_low, dtype=np.float32),
            np.asarray(native.feature_high, dtype=np.float32),
            dtype=np.float32,
        )
        if not native.observe_frames:
            return features, action
        return spaces.Dict({"features": features, **_frame_spaces(native)}), action
    obs: Dict[str, spaces.Space] = {}
    for label, names in zip(native.detector_labels, native.signal_names):
        lim = _native.SIGNAL_LIMIT
        obs[label] = spaces.Box(-lim, lim, shape=(len(names),), dtype=np.float32)
    obs["theta_hat"] = spaces.Box(0.0, 180.0, shape=(1,), dtype=np.float32)
    obs["alarm"] = spaces.MultiBinary(len(native.detector_labels))
    lim = _native.ROBOT_LIMIT
    obs["robot"] = spaces.Box(-lim, lim, shape=(len(native.robot_fields),), dtype=np.float32)
    if native.observe_frames:
        obs.update(_frame_spaces(native))
    return spaces.Dict(obs), action


def _frame_spaces(native: Any) -> Dict[str, spaces.Space]:
    """What ``observe_frames`` adds: ``frame`` (n×n uint8) and, with an event camera
    (``sensor="events"`` or ``[world.camera] kind = "events"``), ``events``: the camera period's ON
    and OFF event counts per pixel (2×n×n uint16)."""
    n = native.frame_size
    out: Dict[str, spaces.Space] = {"frame": spaces.Box(0, 255, shape=(n, n), dtype=np.uint8)}
    if native.event_camera:
        out["events"] = spaces.Box(0, np.iinfo(np.uint16).max, shape=(2, n, n), dtype=np.uint16)
    return out


def _scenario_arg(
    scenario: Union[str, os.PathLike, Sequence[Union[str, os.PathLike]], None],
) -> Union[str, List[str], None]:
    """The native ``scenario`` argument: a name or path, ``suite:NAME`` resolved to its folder, or a
    list of paths (one suite)."""
    if scenario is None:
        return None
    if isinstance(scenario, (str, os.PathLike)):
        s = os.fspath(scenario)
        if isinstance(s, str) and s.startswith("suite:"):
            return suite_path(s[len("suite:") :])
        return str(s)
    paths = [str(os.fspath(p)) for p in scenario]
    if not paths:
        raise _option_error("scenario", scenario, "give at least one scenario file or suite folder")
    return paths


_OPTION_KEYS = (
    "detectors",
    "thresholds",
    "frame_size",
    "observe_frames",
    "action_type",
    "action_config",
    "clip_actions",
    "reward",
    "max_episode_steps",
    "obs_mode",
    "action_repeat",
    "dodge_hold_s",
    "sensor",
    "tiers",
    "seed_stream",
)


def _native_options(kwargs: Mapping[str, Any]) -> str:
    """The native environment's options (JSON) from recorded constructor arguments."""
    return options_json(build_options(**{k: kwargs[k] for k in _OPTION_KEYS}))


def _constructor_kwargs(**kwargs: Any) -> Dict[str, Any]:
    """The constructor arguments of an environment as plain data (what pickling replays)."""
    detectors = kwargs["detectors"]
    scenario = kwargs["scenario"]
    if scenario == DEFAULT_SUITE_ARG and kwargs.get("scenario_toml") is not None:
        # scenario TOML text replaces the registered ids' default suite
        scenario = None
    tiers = kwargs.get("tiers")
    return dict(
        kwargs,
        scenario=_scenario_arg(scenario),
        tiers=[int(t) for t in tiers] if tiers is not None else None,
        detectors=list(detectors) if detectors is not None and not isinstance(detectors, str) else detectors,
        thresholds=dict(kwargs["thresholds"]) if kwargs["thresholds"] is not None else None,
        action_config=_as_dict(kwargs["action_config"]),
        reward=_as_dict(kwargs["reward"]),
    )


SEED_END = 1 << 64
"""Seeds are integers in ``[0, SEED_END)`` (Rust ``u64``); they never wrap around."""


def _seed_arg(seed: Optional[int], num_envs: int = 1) -> Optional[int]:
    """A seed checked to lie in [0, 2**64); with ``num_envs`` environments (seeded ``seed + i``),
    ``seed + num_envs - 1`` must too.

    Raises:
        ValueError: naming the seed and the valid range.
    """
    if seed is None:
        return None
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer in [0, 2**64) or None, got {seed!r}")
    end = SEED_END - (num_envs - 1)
    if not 0 <= int(seed) < end:
        per_env = f" (environment i gets seed + i: with {num_envs} environments, at most 2**64 - {num_envs})"
        raise ValueError(
            f"seed must be an integer in [0, 2**64){per_env if num_envs > 1 else ''}, got {seed!r}; "
            "seeds never wrap around"
        )
    return int(seed)


class EscapeEnv(gym.Env):
    """A robot cruises through a simulated world while objects may fly or drive at it; the agent sees
    looming-detector signals (and optionally the camera frame) and commands velocities to avoid
    collisions without needless dodges.

    ## Description

    One step is ``action_repeat`` camera periods (default 1; a camera period is 1/120 s by
    default; a discrete dodge or stop ``dodge_hold_s`` when set): the action is held that long while
    the detectors see every frame, and the step returns the last observation and the summed reward.
    The world, the rendering, the detectors and the ground truth run in Rust
    (``loomlab_env::EscapeEnv``). At every reset an open-loop pass
    finds whether the episode is a *threat* (an object touches the robot if it keeps cruising), its
    contact time and its escape deadline.

    ## Action Space

    - ``loomlab/Escape-v0``: ``Box(-1, 1, (3,), float32)``: ``[forward, yaw_rate, lateral]``, scaled
      by ``ActionConfig``'s maxima (3 m/s, 1.5 rad/s, 1.5 m/s) to an absolute velocity command.
    - ``loomlab/EscapeDiscrete-v0``: ``Discrete(6)`` (``action_type="manoeuvre"``): the escape
      controller's manoeuvres, each the command the scenario's ``[controller]`` gives for it
      (``EscapeConfig::command``): 0 cruise, 1 sidestep left, 2 sidestep right, 3 stop, 4 reverse,
      5 the planner's choice (the candidate with the largest predicted clearance from every
      perceived object, ``agents/src/planner.rs``).
    - ``action_type="discrete"``: ``Discrete(4)``: 0 none (cruise), 1 dodge left, 2 dodge right
      (the cruise command plus ``dodge_speed_mps`` sideways), 3 stop.

    Both registered ids serve the default suite (``scenario="suite:default"``, at its camera size,
    with its ``[[detectors]]`` rows and their decision rules).

    ## Observation Space

    ``obs_mode="raw"`` (default): a ``Dict`` of one ``Box(-1e6, 1e6)`` per detector label (its
    output then its auxiliary signals, ``signal_names``), ``theta_hat`` (θ̂ in degrees, [0, 180]),
    ``alarm`` (``MultiBinary(D)``), ``robot`` (``x_m, y_m, yaw_rad, forward_mps, yaw_rate_rps,
    lateral_mps, t_s``) and, with ``observe_frames``, ``frame`` (n×n uint8) and, with an event
    camera (``sensor="events"``), ``events`` (the period's ON and OFF event counts, 2×n×n uint16).

    ``obs_mode="normalized"``: one ``Box(low, high, (3·D + 10,), float32)`` of bounded features a
    policy network can take as they are (``D`` detectors; names in ``self._native.feature_names``,
    scales in ``loomlab._native.FEATURE_SCALES``; Rust ``loomlab_env::features`` is their one
    definition); with ``observe_frames`` a ``Dict`` ``{"features", "frame"}``:

    ==========================================  ============================================  ===========
    feature                                     definition                                    range
    ==========================================  ============================================  ===========
    ``{label}.log_output`` (per detector)       sign(y)·ln(1+|y|)/ln(1+1e6), y the output     [-1, 1]
    ``{label}.log_output_rate`` (per detector)  tanh(d log_output/dt / 2 s⁻¹)                 [-1, 1]
    ``theta_hat_rad``                           θ̂ of the first detector giving one (rad)      [0, π]
    ``theta_hat_rate_rps``                      dθ̂/dt (rad/s), clamped                        [-10, 10]
    ``{label}.alarm`` (per detector)            trigger signal ≥ threshold                    {0, 1}
    ``looming_side``                            image x of the looming object, 0 unknown      [-1, 1]
    ``robot.x``, ``robot.y``                    position from the start pose / 5 m, clamped   [-1, 1]
    ``robot.yaw``                               heading from the start heading / π            [-1, 1]
    ``robot.forward/yaw_rate/lateral``          last command / the action scales, clamped     [-1, 1]
    ``robot.time``                              episode time / episode duration               [0, 1]
    ==========================================  ============================================  ===========

    The reset observation has zero signals (the detectors see their first frame in the first step).

    ``obs_mode="privileged"``: one ``Box(low, high, (17,), float32)``: the *true* percept of the most
    threatening object (the looming object in view with the shortest optical τ, else the largest in
    view; zeros when nothing is in view) and the 7 robot features above. It reads ground truth, like
    the reference rows ``ideal_tau`` / ``ideal_course``, whose τ trigger and collision-course gate
    decide on the same percept: a policy trained on it shows whether the task is learnable at all,
    apart from the detectors (the detector observations never read ground truth):

    ==========================================  ============================================  ===========
    feature                                     definition                                    range
    ==========================================  ============================================  ===========
    ``threat.theta_rad``                        true angular size θ (rad)                     [0, π]
    ``threat.theta_rate_rps``                   dθ/dt (rad/s), clamped                        [-10, 10]
    ``threat.inv_tau_ps``                       urgency 1/τ = θ̇/θ (1/s), 0 if not looming      [0, 20]
    ``threat.bearing``                          image x of its reference point                [-1, 1]
    ``threat.bearing_rate``                     d bearing/dt / 4 s⁻¹, clamped                 [-1, 1]
    ``threat.miss_radii``                       |2β̇/θ̇| / 10: predicted miss in object radii   [0, 1]
    ``threat.left_deg``, ``threat.right_deg``   azimuths of its image edges / 90°             [-1, 1]
    ``threat.bottom_deg``, ``threat.top_deg``   elevations of its image edges / 90°           [-1, 1]
    ==========================================  ============================================  ===========

    ## Rewards

    Per step (:class:`RewardConfig`, every weight configurable): ``+survival_per_s·dt`` while
    untouched, ``+progress_per_m·Δs``, ``−effort_per_s·|u − u_cruise|²·dt``,
    ``−unnecessary_dodge_per_s·dt`` while dodging in an episode without a threat,
    ``−unnecessary_dodge_penalty`` once on the first such step (a false alarm),
    ``−collision_penalty`` once on contact, and ``+timely_dodge_bonus`` once on the first dodging
    step of an episode with an evadable threat whose observation lies in the last
    ``timely_dodge_window_s`` (default 0.5 s) before the threat's escape deadline less the lead
    margin (a hit, and an informed one: earlier, the object could not yet be seen to come).
    ``info["reward_terms"]`` reports each term (summed over a repeated action's camera periods).

    Why the bonus: the outcome of a dodge (the collision it avoids) is paid up to ~1 s after the
    decision, tens of decisions later, and a false alarm's cost is paid at once; on the outcome alone
    PPO learns that departing from cruising is costly long before it finds a dodge that pays (the
    README's first RL result collapsed to "never dodge"). The escape deadline (the runner's
    physics-only replays, ``loomlab_scenarios::deadline``) says at the decision whether the dodge was
    in time: ground truth in the reward only, never in the observation.

    ## Episode End

    Terminated when the robot is touched or the scenario's duration is over; truncated after
    ``max_episode_steps`` camera periods. The last ``info`` holds ``outcome``: the threat, the collision, every
    detector's scored row and ``outcome["agent"]``, the agent scored as a detector (its alarm is the
    first observation on which it departed from cruising): what :func:`loomlab.evaluate` reports.

    Args:
        scenario: a shipped scenario name (``loomlab.scenario_names()``), a path to a scenario TOML
            file, a suite (a folder, a list file, ``suite:NAME`` or a list of scenario files), loaded
            as ``loomlab run`` loads it; ``None``: the scenario ``escape_default``.
        scenario_toml: scenario TOML text instead of ``scenario``.
        tiers: suites only: keep the scenarios of these difficulty tiers (0 to 3), as
            ``loomlab run --tier``; ``None``: all.
        seed_stream: ``"train"`` or ``"eval"``: resets draw seeds from that half of the seeds only (the
            top bit of every drawn simulator and expansion seed), so held-out evaluation episodes are
            never training ones; ``None``: either half.
        detectors: detector ids (list or comma-separated, ``"all"``); ``None``: the scenario's.
        thresholds: alarm thresholds by detector id (θ̂ degrees for hopfield, output for baselines,
            the urgency 1/τ in 1/s for rows with trigger = "tau"; the strategy itself comes from the
            scenario's [[detectors]] entry).
        frame_size: camera frame size n (default 64; ``None``: the scenario's).
        observe_frames: include the egocentric frame (uint8, n×n) in the observation.
        action_type: ``"continuous"`` (Box(-1, 1, (3,)): forward, yaw rate, lateral),
            ``"discrete"`` (none, dodge left, dodge right, stop) or ``"manoeuvre"`` (cruise, sidestep
            left, sidestep right, stop, reverse, plan).
        action_config: scales of the action mappings (:class:`ActionConfig` or dict).
        clip_actions: clamp continuous actions into [-1, 1] instead of raising :class:`ActionError`.
        reward: reward weights (:class:`RewardConfig` or dict).
        max_episode_steps: truncate episodes after this many camera periods.
        obs_mode: ``"raw"``, ``"normalized"``, ``"privileged"`` or ``"decision"`` (see Observation Space).
        action_repeat: camera periods each action is held for (default 1: one decision per frame;
            ``python -m loomlab.train`` uses 8, 15 Hz: a dodge of 0.6 s is ~5 decisions, an episode
            ~40 instead of ~300).
        dodge_hold_s: discrete actions: a dodge or stop is held this long in one step (s; default 0:
            ``action_repeat`` periods like every action; ``python -m loomlab.train`` uses 0.6, the
            escape controller's manoeuvre): a dodge is one decision with one outcome.
        sensor: the camera sensor profile every episode runs under: ``"ideal"`` (noiseless,
            instantaneous) or ``"robot"`` (a 4 ms exposure's motion blur, shot and read noise, gain,
            8-bit quantisation, and the perception and actuation latencies of a real robot; the
            detectors, the frames of ``observe_frames`` and the policy all see this camera); default
            ``None``: the scenario file's own sensor keys (``ideal`` unless it sets them). An unknown
            name raises :class:`SensorProfileError` (a ``ValueError``).
        render_mode: ``"rgb_array"`` or ``None``.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 120}

    def __init__(
        self,
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
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self._kwargs = _constructor_kwargs(
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
        )
        self._native = _native.EscapeEnv(self._kwargs["scenario"], scenario_toml, _native_options(self._kwargs))
        _OPEN.add(self)
        self.observation_space, self.action_space = make_spaces(self._native)
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=int(round(1.0 / self._native.dt)))
        self._discrete = self._native.action_kind in ("discrete", "manoeuvre")
        self._action_names = MANOEUVRE_ACTIONS if self._native.action_kind == "manoeuvre" else DISCRETE_ACTIONS

    # --- metadata -------------------------------------------------------------------------------
    @property
    def detector_ids(self) -> list:
        """Chosen detector ids (``hopfield``, ``soc``, …), in the order of ``alarm``."""
        return list(self._native.detector_ids)

    @property
    def detector_labels(self) -> list:
        """Chosen detectors' labels: the per-detector observation keys, in the order of ``alarm``
        (the ids unless the scenario labels its detectors)."""
        return list(self._native.detector_labels)

    @property
    def signal_names(self) -> Dict[str, list]:
        """Names of each detector's signal vector (by label): ``output``, then its auxiliary signals."""
        return dict(zip(self._native.detector_labels, self._native.signal_names))

    @property
    def thresholds(self) -> Dict[str, float]:
        """Alarm thresholds by detector label."""
        return dict(zip(self._native.detector_labels, self._native.thresholds))

    @property
    def dt(self) -> float:
        """Camera period (s): the length of one step."""
        return float(self._native.dt)

    @property
    def adapter(self) -> str:
        """The GPU adapter that renders the frames."""
        return str(self._native.adapter)

    # --- Gymnasium API ----------------------------------------------------------------------------
    def reset(self, *, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None):
        """Starts an episode.

        Args:
            seed: an integer in [0, 2**64) restarting the seed stream; ``None`` continues it.
            options: not supported (must be empty).

        Returns:
            ``(observation, info)``.

        Raises:
            ValueError: the seed is not an integer in [0, 2**64).
            gymnasium.error.ClosedEnvironmentError: the environment was closed.
        """
        seed = _seed_arg(seed)
        self._check_open("reset()")
        super().reset(seed=seed)
        if options:
            raise ScenarioError(f"reset() takes no options, got {sorted(options)}")
        return self._native.reset(seed)

    def step(self, action: Any):
        """Applies an action for one camera period.

        Returns:
            ``(observation, reward, terminated, truncated, info)``.

        Raises:
            ActionError: the action is malformed (wrong shape or type, not real, out of range, NaN).
            gymnasium.error.ClosedEnvironmentError: the environment was closed.
        """
        self._check_open("step()")
        if self._discrete:
            return self._native.step_discrete(_discrete_action(action, self._action_names))
        a0, a1, a2 = _continuous_action(action)
        return self._native.step_continuous(a0, a1, a2)

    def render(self) -> Optional[np.ndarray]:
        if self.render_mode != "rgb_array":
            return None
        self._check_open("render()")
        frame = self._native.frame()
        return np.repeat(frame[:, :, None], 3, axis=2)

    def close(self) -> None:
        """Releases the renderer and the episode and joins the background thread that prepares the
        next episode; ``reset``, ``step`` and ``render`` then raise
        ``gymnasium.error.ClosedEnvironmentError``. Closing twice is allowed. Environments still
        open when the interpreter exits are closed then."""
        self._native.close()
        _OPEN.discard(self)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return bool(self._native.closed)

    def _check_open(self, what: str) -> None:
        if self._native.closed:
            raise ClosedEnvironmentError(
                f"{what} called on a closed environment; close() released it, so make a new environment"
            )

    # --- pickling: the constructor arguments plus the episode's seed stream and actions (replayed) --
    def __getstate__(self) -> Dict[str, Any]:
        closed = self._native.closed
        return {
            "kwargs": self._kwargs,
            "snapshot": None if closed else self._native.snapshot(),
            "closed": closed,
            "np_random": self._np_random,
            "np_random_seed": self._np_random_seed,
        }

    def __setstate__(self, state: Dict[str, Any]) -> None:
        kwargs = dict(state["kwargs"])
        self.__init__(**kwargs)
        if state.get("closed"):
            self.close()
        else:
            self._native.restore(state["snapshot"])
        self._np_random = state.get("np_random")
        self._np_random_seed = state.get("np_random_seed")


def _discrete_action(action: Any, names: Sequence[str] = DISCRETE_ACTIONS) -> int:
    a = np.asarray(action)
    if a.shape != () or not np.issubdtype(a.dtype, np.integer):
        if a.shape == () and np.issubdtype(a.dtype, np.floating) and float(a).is_integer():
            return int(a)
        raise ActionError(
            f"discrete action must be an integer in 0..{len(names) - 1} ({', '.join(names)}), got {action!r}"
        )
    return int(a)


def _real_array(action: Any, expected: str) -> np.ndarray:
    """``action`` as a float32 array, if it holds real numbers (bool, integer or float dtype): complex
    numbers, strings and other objects are :class:`ActionError` (never silently converted)."""
    try:
        a = np.asarray(action)
    except (TypeError, ValueError) as e:
        raise ActionError(f"{expected}, got {action!r}") from e
    if a.dtype.kind not in "biuf":
        raise ActionError(f"{expected} (real numbers: a bool, integer or float dtype), got {a.dtype} array {action!r}")
    return a.astype(np.float32)


def _continuous_action(action: Any) -> Tuple[float, float, float]:
    a = _real_array(action, "continuous action must be 3 numbers [forward, yaw_rate, lateral] in [-1, 1]")
    if a.shape != (3,):
        raise ActionError(
            f"continuous action must have shape (3,) [forward, yaw_rate, lateral] in [-1, 1], got shape {a.shape}"
        )
    return float(a[0]), float(a[1]), float(a[2])
