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
        # θ̂ must be an angle (0 to 180 degrees)
        return {"output": float(frame.mean()), "angular_size_deg": float(min(self.t, 90)), "image_x": 0.0}


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
        (Raises(), r"`raises`: step\(frame\) at frame 0: RuntimeError: boom in step"),
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
    # slow enough to be interrupted after its first episode; SLOW_STEP_S=0 for the resumed run;
    # SLOW_MARK: a file made on the first step (the run is in its episodes)
    def step(self, frame):
        mark = os.environ.get("SLOW_MARK")
        if mark and not os.path.exists(mark):
            open(mark, "w").close()
        time.sleep(float(os.environ.get("SLOW_STEP_S", "0.01")))
        return super().step(frame)
"""


def _sigint_default() -> None:
    """A child's SIGINT as a terminal's foreground process has it: a shell's background job (CI run
    with `&`, nohup) ignores SIGINT, its children inherit that, and then Python installs no
    KeyboardInterrupt handler and an interrupt test waits for its timeout."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _python(tmp_path: Path, args: list[str], extra_env: dict[str, str] | None = None, **kw) -> subprocess.Popen:
    """`python ARGS…` in tmp_path with MODULE importable as `my_detectors`."""
    (tmp_path / "my_detectors.py").write_text(MODULE)
    env = dict(os.environ, PYTHONPATH=str(tmp_path), **(extra_env or {}))
    return subprocess.Popen(
        [sys.executable, *args],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_sigint_default,
        **kw,
    )


def _cli(tmp_path: Path, *args: str, extra_env: dict[str, str] | None = None, **kw) -> subprocess.Popen:
    return _python(tmp_path, ["-m", "loomlab", "run", str(SUITE), *args], extra_env, **kw)


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


class Returns:
    """A detector returning the same answer every frame."""

    def __init__(self, answer) -> None:
        self.answer = answer

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray):
        return self.answer


@pytest.mark.parametrize(
    "answer, label, message",
    [
        (float("nan"), "nan_out", r"`nan_out`: step\(frame\) at frame 0 of the episode returned output = NaN"),
        (float("inf"), "inf_out", r"`inf_out`: .* at frame 0 .*output = inf; outputs must be finite"),
        ({"output": -float("inf")}, "minus_inf", r"`minus_inf`: .*output = -inf"),
        ({"output": 1.0, "angular_size_deg": float("nan")}, "theta_nan", r"`theta_nan`: .*angular_size_deg = NaN"),
        ({"output": 1.0, "angular_size_deg": -5.0}, "theta_neg", r"`theta_neg`: .*angular_size_deg = -5; .*0 to 180"),
        ({"output": 1.0, "angular_size_deg": 1e9}, "theta_big", r"`theta_big`: .*angular_size_deg = 1000000000"),
        ({"output": 1.0, "image_x": float("inf")}, "x_inf", r"`x_inf`: .*image_x = inf"),
    ],
)
def test_non_finite_outputs_and_impossible_theta_are_refused(answer, label, message):
    """An inf output was scored a hit and a θ̂ of 1e9 gave a θ̂ error of 1e8: refused with the
    detector's label and the frame."""
    detector = loomlab.PythonDetector(Returns(answer), label=label, threshold=1.0)
    with pytest.raises(loomlab.DetectorError, match=message):
        loomlab.run_suite(SUITE, detectors=["soc", detector], limit=1, size=32)


def test_angular_size_trigger_without_theta_is_refused():
    """A detector alarmed on θ̂ that never returns one would never alarm."""
    detector = loomlab.PythonDetector(NumpySoc(), label="no_theta", threshold=10.0, trigger="angular_size")
    with pytest.raises(loomlab.DetectorError, match=r"`no_theta`: .*no angular_size_deg, but its trigger is"):
        loomlab.run_suite(SUITE, detectors=["soc", detector], limit=1, size=32)
    # None is an answer: no estimate on this frame
    quiet = loomlab.PythonDetector(
        Returns({"output": 0.0, "angular_size_deg": None}), label="quiet", threshold=10.0, trigger="angular_size"
    )
    report = loomlab.run_suite(SUITE, detectors=["soc", quiet], limit=1, size=32)
    assert "quiet" in report["detectors"]


def test_a_reference_row_label_is_refused_naming_the_python_detector():
    message = r"PythonDetector `oracle` \(Python detector .*NumpySoc.*reference row"
    with pytest.raises(loomlab.DetectorError, match=message):
        loomlab.run_suite(SUITE, detectors=[loomlab.PythonDetector(NumpySoc(), label="oracle", threshold=1)], limit=1)


def test_run_suite_refuses_what_the_cli_refuses(tmp_path):
    with pytest.raises(ValueError, match="limit=0 must be at least 1"):
        loomlab.run_suite(SUITE, limit=0)
    with pytest.raises(ValueError, match="jobs=0 must be at least 1"):
        loomlab.run_suite(SUITE, jobs=0)
    with pytest.raises(ValueError, match="jobs=-2 must be at least 1"):
        loomlab.run_suite(SUITE, jobs=-2, out=tmp_path / "run")
    with pytest.raises(TypeError, match="limit=1.5 must be an int"):
        loomlab.run_suite(SUITE, limit=1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="resume=True .* give out="):
        loomlab.run_suite(SUITE, resume=True)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("out", [False, True])
def test_a_nan_in_a_detector_entry_names_the_detector_and_key(tmp_path, out):
    """It went through JSON or TOML text and came back as "expected value at line 1 column 29"."""
    kwargs = {"out": tmp_path / "run"} if out else {}
    message = r"detectors entry 0 \(`soc`\): threshold = nan; numbers must be finite"
    with pytest.raises(loomlab.ScenarioError, match=message):
        loomlab.run_suite(SUITE, detectors=[{"id": "soc", "threshold": float("nan")}], limit=1, **kwargs)
    with pytest.raises(loomlab.ScenarioError, match=r"entry 1 \(`lo`\): params.k\[1\] = inf"):
        loomlab.run_suite(
            SUITE, detectors=[{"id": "soc"}, {"id": "soc", "label": "lo", "params": {"k": [1, float("inf")]}}], limit=1
        )


def test_detectors_may_be_one_str():
    """A str was iterated as a list of one-letter ids ("unknown detector `s`")."""
    with pytest.raises(loomlab.ScenarioError, match="unknown detector `nosuch`"):
        loomlab.run_suite(SUITE, detectors="nosuch", limit=1)
    with pytest.raises(loomlab.ScenarioError, match="unknown detector `nosuch`"):
        loomlab.run_suite(SUITE, detectors="soc, nosuch", limit=1)
    report = loomlab.run_suite(SUITE, detectors="soc", limit=1, size=32)
    assert "soc" in report["detectors"] and "hopfield" not in report["detectors"]


def test_python_m_loomlab_run_refuses_a_clashing_label_with_exit_2(tmp_path):
    """A label clashing with a built-in detector printed a traceback and exited 1 (regressions)."""
    for label, reason in (("soc", "`soc` is registered already"), ("oracle", "reference row")):
        p = _cli(
            tmp_path,
            "--detector",
            "my_detectors:NumpySoc",
            "--label",
            label,
            "--limit",
            "1",
            "--out",
            str(tmp_path / "x"),
        )
        _, stderr = p.communicate(timeout=120)
        assert p.returncode == 2, stderr
        assert "Traceback" not in stderr and stderr.startswith("error: PythonDetector") and reason in stderr, stderr


def test_a_second_ctrl_c_stops_run_suite_at_once(tmp_path):
    """Without out, run_suite waited for the episodes in flight after a second Ctrl-C; now it
    stops at once with 130, as the CLI's second Ctrl-C does."""
    script = (
        "import sys, loomlab, my_detectors\n"
        "print('started', flush=True)\n"
        f"loomlab.run_suite({str(SUITE)!r}, detectors=['soc', loomlab.PythonDetector(my_detectors.Slow)], "
        "limit=4, size=32, jobs=1)\n"
    )
    mark = tmp_path / "stepping"
    p = _python(tmp_path, ["-c", script], {"SLOW_STEP_S": "0.2", "SLOW_MARK": str(mark)})
    assert p.stdout is not None and p.stdout.readline().strip() == "started"
    # inside run_suite, in the first episode (a frame takes 0.2 s): on a loaded machine the run's
    # setup can outlast a fixed sleep, and two interrupts that arrive before the run watches for
    # them are one to Python
    waited = time.monotonic()
    while not mark.exists() and time.monotonic() - waited < 90.0:
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    time.sleep(1.0)
    started = time.monotonic()
    p.send_signal(signal.SIGINT)
    _, stderr = p.communicate(timeout=120)
    assert p.returncode == 130, stderr[-2000:]
    assert "second interrupt: stopped" in stderr
    assert time.monotonic() - started < 5.0


class Objects:
    """Returns only a list of two objects, the first one growing: θ̂ = frame index (degrees); its
    θ̂ stands for the output and ``angular_size_deg``."""

    threshold = 5.0
    trigger = "angular_size"

    def reset(self) -> None:
        self.t = 0

    def step(self, frame: np.ndarray) -> dict:
        self.t += 1
        theta = float(min(self.t, 90))
        return {
            "objects": [
                {"id": 7, "box": [-0.1, 0.1, -0.05, 0.15], "theta_deg": theta, "tau_s": None},
                {"id": 2, "box": [0.5, 0.6, -0.2, -0.1], "theta_deg": 3.0, "tau_s": 1.5},
            ]
        }


def test_a_detector_may_return_a_list_of_objects():
    """The first object stands for the detector's output and θ̂: it alarms as the same θ̂ given as
    ``angular_size_deg`` does."""
    report = loomlab.run_suite(
        SUITE, detectors=["soc", loomlab.PythonDetector(Dict()), loomlab.PythonDetector(Objects())], limit=1, size=32
    )
    objects, plain = report["detectors"]["objects"], report["detectors"]["dict"]
    assert objects["hits"] + objects["false_alarms"] == 1
    for key in ("hits", "misses", "false_alarms", "correct_rejections"):
        assert objects[key] == plain[key], key
    # the time the steps take through the runner's glue: the list is accepted every frame
    assert loomlab._native._time_python_detector(loomlab.PythonDetector(Objects()), 32, 3) >= 0.0


def _object(**change):
    good = {"id": 1, "box": [-0.2, 0.2, -0.1, 0.3], "theta_deg": 4.0}
    good.update(change)
    return {key: value for key, value in good.items() if value is not ...}


@pytest.mark.parametrize(
    "objects, message",
    [
        ({"id": 1}, r"objects = \{'id': 1\}, which is not a list"),
        ([3.0], r"objects\[0\] = 3.0, which is not a dict with keys id, box, theta_deg, tau_s"),
        ([_object(id=1.0)], r"objects\[0\]\.id = 1\.0; ids are ints"),
        ([_object(id=True)], r"objects\[0\]\.id = True; ids are ints"),
        ([_object(id=-1)], r"objects\[0\]\.id = -1; ids are ints"),
        ([_object(), _object()], r"objects\[1\]\.id = 1, the id of an earlier object"),
        ([_object(box=[0.0, 1.5, 0.0, 0.1])], r"objects\[0\]\.box = \[0\.0, 1\.5, 0\.0, 0\.1\]; .*in \[-1, 1\]"),
        ([_object(box=[0.3, 0.1, 0.0, 0.1])], r"objects\[0\]\.box = .*x0 <= x1"),
        ([_object(box=[0.0, float("nan"), 0.0, 0.1])], r"objects\[0\]\.box = \[0\.0, nan, .*finite"),
        ([_object(box=[0.0, 0.1])], r"objects\[0\]\.box = \[0\.0, 0\.1\]; a box is \[x0, x1, y0, y1\]"),
        ([_object(theta_deg=float("inf"))], r"objects\[0\]\.theta_deg = inf; .*0 to 180"),
        ([_object(theta_deg=...)], r"objects\[0\] without \"theta_deg\""),
        ([_object(tau_s=0.0)], r"objects\[0\]\.tau_s = 0\.0; .*> 0 \(None: no estimate\)"),
        ([_object(colour=1)], r"objects\[0\] with the key \"colour\"; its keys are id, box, theta_deg, tau_s"),
    ],
)
def test_bad_objects_are_refused_naming_the_label_frame_and_key(objects, message):
    detector = loomlab.PythonDetector(Returns({"output": 1.0, "objects": objects}), label="lister", threshold=1.0)
    expected = r"`lister`: step\(frame\) at frame 0 of the episode returned " + message
    with pytest.raises(loomlab.DetectorError, match=expected):
        loomlab._native._time_python_detector(detector, 32, 2)


class EventCount:
    """The built-in `event_soc` in Python: the number of events of the period (a `step` with the
    keyword `events` gets the event camera's events, None without one)."""

    def reset(self) -> None:
        pass

    def step(self, frame: np.ndarray, events=None) -> float:
        if events is None:
            return 0.0
        n = frame.shape[0]
        assert events["on"].shape == (n, n) and events["off"].shape == (n, n)
        assert len(events["x"]) == len(events["y"]) == len(events["polarity"]) == len(events["t_s"])
        assert int(events["on"].sum() + events["off"].sum()) == len(events["t_s"])
        assert np.all(np.diff(events["t_s"]) >= 0)
        assert np.all((events["t_s"] > events["t_start_s"]) & (events["t_s"] <= events["t_end_s"]))
        return float(len(events["t_s"]))


def test_a_python_detector_reads_the_event_camera(tmp_path):
    """Under an event camera (a suite's `sensor = "events"`) a `step(frame, events=...)` gets each
    period's events: counting them gives the built-in `event_soc` row."""
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "suite.toml").write_text('sensor = "events"\n')
    (suite / "slow_ball.toml").write_text((SUITE / "slow_ball_plain.toml").read_text())
    threshold = 40.0
    mine = loomlab.PythonDetector(EventCount, label="py_events", threshold=threshold)
    report = loomlab.run_suite(
        suite, detectors=[{"id": "event_soc", "threshold": threshold}, mine], limit=2, size=32, jobs=1
    )
    builtin, python = report["detectors"]["event_soc"], report["detectors"]["py_events"]
    assert python == builtin
    assert builtin["hits"] + builtin["false_alarms"] > 0
