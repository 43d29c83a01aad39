"""Type stubs of the Rust extension ``loomlab._native`` (the engine under ``loomlab.EscapeEnv``).

Checked against the built module by ``make lint`` (``python -m mypy.stubtest loomlab._native``).
"""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = [
    "EscapeEnv",
    "EscapeVectorEnv",
    "SweepPlan",
    "RunRequest",
    "run_cli",
    "run_suite",
    "evaluation_report",
    "calibrate_thresholds",
    "scenario_names",
    "scenario_toml",
    "detector_ids",
    "_raise",
    "_time_python_detector",
    "LoomlabError",
    "ScenarioError",
    "RenderError",
    "DetectorError",
    "ActionError",
    "SweepError",
    "ROBOT_FIELDS",
    "SIGNAL_LIMIT",
    "ROBOT_LIMIT",
    "REWARD_DEFAULTS",
    "ACTION_DEFAULTS",
    "DISCRETE_ACTIONS",
    "CONTINUOUS_ACTION_NAMES",
    "MANOEUVRE_ACTIONS",
    "DEFAULT_SUITE",
    "FEATURE_SCALES",
    "OBS_MODES",
    "SENSOR_PROFILES",
    "AGENT_LABEL",
    "__version__",
]

__version__: str
ROBOT_FIELDS: List[str]
SIGNAL_LIMIT: float
ROBOT_LIMIT: float
REWARD_DEFAULTS: Dict[str, float]
ACTION_DEFAULTS: Dict[str, float]
DISCRETE_ACTIONS: Tuple[str, ...]
CONTINUOUS_ACTION_NAMES: Tuple[str, ...]
MANOEUVRE_ACTIONS: Tuple[str, ...]
DEFAULT_SUITE: str
FEATURE_SCALES: Dict[str, float]
OBS_MODES: Tuple[str, ...]
SENSOR_PROFILES: Tuple[str, ...]
AGENT_LABEL: str

class LoomlabError(Exception):
    """Base class of every error raised by loomlab."""

class ScenarioError(LoomlabError):
    """A scenario could not be found, read, parsed or expanded, or an environment option is invalid."""

class RenderError(LoomlabError):
    """No GPU adapter (install mesa-vulkan-drivers for a CPU one), or rendering failed."""

class DetectorError(LoomlabError):
    """A detector id is unknown, a detector parameter is invalid or a detector failed."""

class ActionError(LoomlabError):
    """An action has the wrong shape or type, is out of range or not finite."""

class SweepError(LoomlabError):
    """A sweep's output folder holds another sweep, or a shard's results do not match the plan."""

# raw: a dict of arrays; normalized: the feature array (a dict {features, frame} with frames)
_Obs = Any
_Info = Dict[str, Any]

@final
class EscapeEnv:
    """One environment (the engine of the Gymnasium class ``loomlab.EscapeEnv``)."""

    def __new__(
        cls,
        scenario: Union[str, Sequence[str], None] = None,
        scenario_toml: Optional[str] = None,
        options_json: str = "{}",
    ) -> Self: ...
    @staticmethod
    def from_suite(
        suite: Optional[str], seed: int, limit: Optional[int] = None, options_json: str = "{}"
    ) -> EscapeEnv: ...
    @property
    def episode_seed(self) -> Optional[int]: ...
    @property
    def episode_scenario(self) -> Optional[str]: ...
    @property
    def num_episodes(self) -> int: ...
    def reset_to_episode(self, index: int) -> Tuple[_Obs, _Info]: ...
    @property
    def scenario_name(self) -> str: ...
    @property
    def detector_labels(self) -> List[str]: ...
    @property
    def detector_ids(self) -> List[str]: ...
    @property
    def signal_names(self) -> List[List[str]]: ...
    @property
    def thresholds(self) -> List[float]: ...
    @property
    def frame_size(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def duration_steps(self) -> int: ...
    @property
    def action_kind(self) -> str: ...
    @property
    def observe_frames(self) -> bool: ...
    @property
    def event_camera(self) -> bool: ...
    @property
    def adapter(self) -> str: ...
    @property
    def obs_mode(self) -> str: ...
    @property
    def feature_names(self) -> List[str]: ...
    @property
    def feature_low(self) -> List[float]: ...
    @property
    def feature_high(self) -> List[float]: ...
    @property
    def robot_fields(self) -> List[str]: ...
    def reset(self, seed: Optional[int] = None) -> Tuple[_Obs, _Info]: ...
    def step_continuous(self, a0: float, a1: float, a2: float) -> Tuple[_Obs, float, bool, bool, _Info]: ...
    def step_discrete(self, index: int) -> Tuple[_Obs, float, bool, bool, _Info]: ...
    def frame(self) -> npt.NDArray[np.uint8]: ...
    def snapshot(self) -> str: ...
    def restore(self, snapshot_json: str) -> Optional[Tuple[_Obs, _Info]]: ...
    def close(self) -> None: ...
    @property
    def closed(self) -> bool: ...

@final
class EscapeVectorEnv:
    """N environments stepped on Rust threads (the engine of ``loomlab.EscapeVectorEnv``)."""

    def __new__(
        cls,
        num_envs: int,
        scenario: Union[str, Sequence[str], None] = None,
        scenario_toml: Optional[str] = None,
        options_json: str = "{}",
    ) -> Self: ...
    @property
    def scenario_name(self) -> str: ...
    @property
    def detector_labels(self) -> List[str]: ...
    @property
    def detector_ids(self) -> List[str]: ...
    @property
    def signal_names(self) -> List[List[str]]: ...
    @property
    def thresholds(self) -> List[float]: ...
    @property
    def frame_size(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def duration_steps(self) -> int: ...
    @property
    def action_kind(self) -> str: ...
    @property
    def observe_frames(self) -> bool: ...
    @property
    def event_camera(self) -> bool: ...
    @property
    def adapter(self) -> str: ...
    @property
    def obs_mode(self) -> str: ...
    @property
    def feature_names(self) -> List[str]: ...
    @property
    def feature_low(self) -> List[float]: ...
    @property
    def feature_high(self) -> List[float]: ...
    @property
    def robot_fields(self) -> List[str]: ...
    @property
    def num_envs(self) -> int: ...
    def reset(self, seed: Optional[int] = None) -> Tuple[_Obs, _Info]: ...
    def step_continuous(
        self, actions: npt.NDArray[np.float32]
    ) -> Tuple[_Obs, npt.NDArray[np.float64], npt.NDArray[np.bool_], npt.NDArray[np.bool_], _Info]: ...
    def step_discrete(
        self, actions: npt.NDArray[np.int64]
    ) -> Tuple[_Obs, npt.NDArray[np.float64], npt.NDArray[np.bool_], npt.NDArray[np.bool_], _Info]: ...
    def step_train(
        self, actions: npt.NDArray[Any]
    ) -> Tuple[
        npt.NDArray[np.float32],
        npt.NDArray[np.float32],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        npt.NDArray[np.float32],
        List[Tuple[int, Dict[str, Any]]],
    ]: ...
    def reset_envs(self, indices: List[int]) -> Tuple[_Obs, _Info]: ...
    def frames(self) -> npt.NDArray[np.uint8]: ...
    def snapshot(self) -> str: ...
    def restore(self, snapshot_json: str) -> Optional[Tuple[_Obs, _Info]]: ...
    def close(self) -> None: ...
    @property
    def closed(self) -> bool: ...

@final
class SweepPlan:
    def __new__(cls, path: str, limit: Optional[int] = None) -> Self: ...
    @property
    def name(self) -> str: ...
    @property
    def path(self) -> str: ...
    @property
    def suite(self) -> str: ...
    @property
    def fingerprint(self) -> str: ...
    @property
    def episode_count(self) -> int: ...
    @property
    def shard_count(self) -> int: ...
    def points(self) -> List[Tuple[str, str, Dict[str, str]]]: ...
    def shard(self, i: int) -> Tuple[int, int, int, int]: ...
    def run_shard(self, i: int, jobs: Optional[int] = None) -> str: ...
    def open_out(self, out: str, restart: bool = False) -> List[bool]: ...
    def write_shard(self, out: str, i: int, csv: str) -> None: ...
    def finish(self, out: str, wall_time_s: float, top: int = 10) -> str: ...

@final
class RunRequest:
    """What ``loomlab.run_suite`` asks ``loomlab run`` to do (checked when run, as the CLI's flags are)."""

    def __new__(
        cls,
        suite: str,
        *,
        out: Optional[str] = None,
        seed: int = 0,
        size: Optional[int] = None,
        limit: Optional[int] = None,
        detectors: Optional[List[str]] = None,
        detectors_file: Optional[str] = None,
        entries: List[Dict[str, Any]] = [],
        jobs: Optional[int] = None,
        resume: bool = False,
    ) -> Self: ...
    @property
    def out(self) -> Optional[str]: ...

def run_suite(request: RunRequest, python: List[Any]) -> str: ...
def run_cli(args: List[str], detectors: List[Any], command: Optional[List[str]] = None) -> int: ...
def _time_python_detector(detector: Any, n: int, frames: int) -> float: ...
def evaluation_report(
    suite: Optional[str],
    seeds: List[int],
    label: str,
    agent_rows_json: str,
    limit: Optional[int] = None,
    options_json: str = "{}",
    jobs: Optional[int] = None,
) -> str: ...
def calibrate_thresholds(
    suite: Optional[str],
    seeds: List[int],
    false_alarm_rate: float,
    limit: Optional[int] = None,
    options_json: str = "{}",
    jobs: Optional[int] = None,
) -> Dict[str, Optional[float]]: ...
def scenario_names() -> List[str]: ...
def scenario_toml(name: str) -> str: ...
def detector_ids() -> List[str]: ...
def _raise(kind: str) -> None: ...
