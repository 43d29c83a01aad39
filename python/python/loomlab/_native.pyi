"""Type stubs of the Rust extension ``loomlab._native`` (the engine under ``loomlab.EscapeEnv``).

Checked against the built module by ``make lint`` (``python -m mypy.stubtest loomlab._native``).
"""

from typing import Any, Dict, List, Optional, Tuple, final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = [
    "EscapeEnv",
    "EscapeVectorEnv",
    "SweepPlan",
    "run_suite",
    "scenario_names",
    "scenario_toml",
    "detector_ids",
    "_raise",
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

_Obs = Dict[str, npt.NDArray[Any]]
_Info = Dict[str, Any]

@final
class EscapeEnv:
    """One environment (the engine of the Gymnasium class ``loomlab.EscapeEnv``)."""

    def __new__(
        cls, scenario: Optional[str] = None, scenario_toml: Optional[str] = None, options_json: str = "{}"
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
    def adapter(self) -> str: ...
    @property
    def robot_fields(self) -> List[str]: ...
    def reset(self, seed: Optional[int] = None) -> Tuple[_Obs, _Info]: ...
    def step_continuous(self, a0: float, a1: float, a2: float) -> Tuple[_Obs, float, bool, bool, _Info]: ...
    def step_discrete(self, index: int) -> Tuple[_Obs, float, bool, bool, _Info]: ...
    def frame(self) -> npt.NDArray[np.uint8]: ...
    def snapshot(self) -> str: ...
    def restore(self, snapshot_json: str) -> Optional[Tuple[_Obs, _Info]]: ...

@final
class EscapeVectorEnv:
    """N environments stepped on Rust threads (the engine of ``loomlab.EscapeVectorEnv``)."""

    def __new__(
        cls,
        num_envs: int,
        scenario: Optional[str] = None,
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
    def adapter(self) -> str: ...
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
    def frames(self) -> npt.NDArray[np.uint8]: ...

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

def run_suite(
    suite: str,
    seed: int = 0,
    size: Optional[int] = None,
    limit: Optional[int] = None,
    detectors: Optional[List[str]] = None,
    detectors_file: Optional[str] = None,
    jobs: Optional[int] = None,
) -> str: ...
def scenario_names() -> List[str]: ...
def scenario_toml(name: str) -> str: ...
def detector_ids() -> List[str]: ...
def _raise(kind: str) -> None: ...
