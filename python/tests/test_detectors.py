"""Python detectors (loomlab.PythonDetector) scored by the Rust runner, as the built-in ones are."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Optional

import numpy as np
import pytest

import loomlab

REPO = Path(__file__).resolve().parents[2]
SUITE = REPO / "scenarios" / "suites" / "default"
ROW_KEYS = ("hits", "misses", "false_alarms", "correct_rejections", "collisions", "evaded", "episodes")


class NumpySoc:
    """The built-in `soc` in numpy: Σ|F(t) − F(t−1)|, 0 on the first frame."""

    def __init__(self) -> None:
        self.previous: Optional[np.ndarray] = None

    def reset(self) -> None:
        self.previous = None

    def step(self, frame: np.ndarray) -> float:
        assert frame.dtype == np.float32 and frame.ndim == 2 and frame.shape[0] == frame.shape[1]
        f = frame.astype(np.float64)
        previous, self.previous = self.previous, f
        return 0.0 if previous is None else float(np.abs(f - previous).sum())


def test_numpy_soc_gives_the_builtin_soc_rows():
    """A numpy SOC at the built-in row's threshold: the same hits, false alarms and collisions, on
    the first 12 episodes of the default suite (`camera_shake`: threats and non-threats, alarms and
    closed-loop escapes), per scenario and pooled."""
    threshold = 60.0
    mine = loomlab.PythonDetector(NumpySoc(), label="numpy_soc", threshold=threshold)
    report = loomlab.run_suite(SUITE, detectors=[{"id": "soc", "threshold": threshold}, mine], limit=12, jobs=2)
    builtin, python = report["detectors"]["soc"], report["detectors"]["numpy_soc"]
    for key in ROW_KEYS:
        assert python[key] == builtin[key], key
    # every score of the row, alarm times and ROC included (the outputs agree to rounding)
    assert python == builtin
    # the sample exercises alarms on both classes and escapes that avoid a collision
    assert builtin["hits"] > 0 and builtin["false_alarms"] > 0
    assert 0 < builtin["collisions"] < builtin["hits"] + builtin["misses"]
    for name, scenario in report["scenarios"].items():
        for key in ROW_KEYS:
            assert scenario["detectors"]["numpy_soc"][key] == scenario["detectors"]["soc"][key], (name, key)


def test_the_report_has_the_keys_of_loomlab_run():
    report = loomlab.run_suite(SUITE, detectors=["soc", loomlab.PythonDetector(NumpySoc, threshold=270)], limit=2)
    assert set(report["detectors"]["numpy_soc"]) == set(report["detectors"]["soc"])
    assert report["episodes"] == 2


class Dict:
    """Returns a dict with θ̂; triggered on it."""

    threshold = 5.0
    trigger = "angular_size"

    def reset(self) -> None:
        self.t = 0

    def step(self, frame: np.ndarray) -> dict:
        self.t += 1
        return {"output": float(frame.mean()), "angular_size_deg": float(self.t), "image_x": 0.0}


def test_a_dict_with_theta_can_trigger():
    report = loomlab.run_suite(SUITE, detectors=["soc", loomlab.PythonDetector(Dict())], limit=1, size=32)
    row = report["detectors"]["dict"]
    # θ̂ = frame index reaches 5 on frame 5: every episode alarms
    assert row["hits"] + row["false_alarms"] == 1


class EgoForward:
    """Outputs the forward speed of its efference copy (``step(frame, ego)``)."""

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray, ego: Optional[dict]) -> float:
        assert ego is not None and set(ego) == {
            "forward_mps",
            "yaw_rate_rps",
            "lateral_mps",
            "dt_s",
            "rotation_rad",
            "translation_m",
            "height_m",
            "pitch_rad",
            "roll_rad",
        }
        return float(ego["forward_mps"])


def test_a_step_with_two_arguments_gets_the_efference_copy(tmp_path):
    from conftest import SHORT_SCENARIO  # the robot cruises at 1 m/s

    scenario = tmp_path / "short.toml"
    scenario.write_text(SHORT_SCENARIO.split("[[world.projectiles]]")[0])  # no threat: alarms are false
    below = loomlab.PythonDetector(EgoForward, label="below", threshold=0.5)
    above = loomlab.PythonDetector(EgoForward, label="above", threshold=1.5)
    report = loomlab.run_suite(scenario, detectors=["soc", below, above], limit=1)
    alarms = {k: report["detectors"][k]["hits"] + report["detectors"][k]["false_alarms"] for k in ("below", "above")}
    assert alarms == {"below": 1, "above": 0}


class Raises:
    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> float:
        raise RuntimeError("boom in step")


class BadKey:
    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> dict:
        return {"output": 1.0, "colour": 2.0}


class NotANumber:
    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray) -> str:
        return "high"


@pytest.mark.parametrize(
    "detector, message",
    [
        (Raises(), r"`raises`: step\(frame\): RuntimeError: boom in step"),
        (BadKey(), r"`bad_key`: .*\"colour\"; the keys are output, angular_size_deg"),
        (NotANumber(), r"`not_a_number`: .*'high', which is not a number"),
    ],
)
def test_a_failing_detector_is_a_detector_error_naming_it(detector, message):
    with pytest.raises(loomlab.DetectorError, match=message):
        loomlab.run_suite(SUITE, detectors=["soc", loomlab.PythonDetector(detector, threshold=1.0)], limit=1, size=32)


def test_bad_wrappers_are_refused_with_the_fix():
    with pytest.raises(TypeError, match="no method reset"):
        loomlab.PythonDetector(object(), threshold=1.0)
    with pytest.raises(ValueError, match="give threshold"):
        loomlab.PythonDetector(NumpySoc())
    with pytest.raises(ValueError, match="trigger 'tau'"):
        loomlab.PythonDetector(NumpySoc(), threshold=1.0, trigger="tau")
    with pytest.raises(ValueError, match="label 'a b'"):
        loomlab.PythonDetector(NumpySoc(), threshold=1.0, label="a b")
    with pytest.raises(loomlab.DetectorError, match="`soc` is registered already"):
        loomlab.run_suite(SUITE, detectors=[loomlab.PythonDetector(NumpySoc(), label="soc", threshold=1)], limit=1)
    with pytest.raises(TypeError, match="give ids"):
        loomlab.run_suite(SUITE, detectors=[3], limit=1)  # type: ignore[list-item]


MODULE = """
import os
import time
import numpy as np

class NumpySoc:
    threshold = 60.0

    def reset(self):
        self.previous = None

    def step(self, frame):
        f = frame.astype(np.float64)
        previous, self.previous = self.previous, f
        return 0.0 if previous is None else float(np.abs(f - previous).sum())

class Slow(NumpySoc):
    # slow enough to be interrupted after its first episode; SLOW_STEP_S=0 for the resumed run
    def step(self, frame):
        time.sleep(float(os.environ.get("SLOW_STEP_S", "0.01")))
        return super().step(frame)
"""


def _cli(tmp_path: Path, *args: str, extra_env: dict[str, str] | None = None, **kw) -> subprocess.Popen:
    (tmp_path / "my_detectors.py").write_text(MODULE)
    env = dict(os.environ, PYTHONPATH=str(tmp_path), **(extra_env or {}))
    return subprocess.Popen(
        [sys.executable, "-m", "loomlab", "run", str(SUITE), *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **kw,
    )


def test_python_m_loomlab_run_writes_the_run_folder(tmp_path):
    out = tmp_path / "run"
    p = _cli(
        tmp_path,
        "--detector",
        "my_detectors:NumpySoc",
        "--label",
        "np_soc",
        "--detectors",
        "soc",
        "--limit",
        "3",
        "--size",
        "32",
        "--out",
        str(out),
    )
    stdout, stderr = p.communicate(timeout=600)
    assert p.returncode == 0, stderr
    for name in ("report.json", "report.html", "episodes.csv", "manifest.json", "roc.png"):
        assert (out / name).is_file(), name
    report = json.loads((out / "report.json").read_text())
    assert {"soc", "np_soc"} <= set(report["detectors"])
    assert "np_soc" in (out / "report.html").read_text()
    rows = (out / "episodes.csv").read_text().splitlines()
    assert sum(",np_soc," in r for r in rows) == 3, "one row per episode"
    # bad input: exit 2 with the reason
    p = _cli(tmp_path, "--detector", "my_detectors:Nope", "--out", str(tmp_path / "x"))
    _, stderr = p.communicate(timeout=60)
    assert p.returncode == 2 and "has no 'Nope'" in stderr


def test_ctrl_c_keeps_the_finished_episodes_and_resume_completes(tmp_path):
    out = tmp_path / "run"
    args = (
        "--detector",
        "my_detectors:Slow",
        "--detectors",
        "soc",
        "--limit",
        "6",
        "--size",
        "32",
        "--jobs",
        "1",
        "--out",
        str(out),
        "--no-html",
        "--no-plots",
    )
    p = _cli(tmp_path, *args)
    csv = out / "episodes.csv"
    deadline = time.monotonic() + 300
    # interrupt once the first episode is saved
    while time.monotonic() < deadline and p.poll() is None:
        if csv.is_file() and len(csv.read_text().splitlines()) > 1:
            break
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    _, stderr = p.communicate(timeout=300)
    manifest = json.loads((out / "manifest.json").read_text())
    if p.returncode == 0:
        pytest.skip("the run finished before the interrupt arrived")
    assert p.returncode == 130, stderr
    assert manifest["state"] == "interrupted" and "--resume" in stderr
    saved = len(csv.read_text().splitlines())
    assert saved > 1
    p = _cli(tmp_path, *args, "--resume", extra_env={"SLOW_STEP_S": "0"})
    _, stderr = p.communicate(timeout=600)
    assert p.returncode == 0, stderr
    assert json.loads((out / "report.json").read_text())["episodes"] == 6
