"""Shared fixtures: a short scenario (n = 32, 0.6 s) keeps the suite fast on 2 cores."""

from __future__ import annotations

import pytest

SHORT_SCENARIO = """
name = "short_head_on"

[episode]
duration_s = 0.6

[robot]
forward_mps = 1.0

[[detectors]]
id = "hopfield"
threshold = 10.0

[[detectors]]
id = "soc"

[world]
camera = { n = 32, fov_deg = 60.0 }

[[world.scenery]]
kind = "wall"
name = "backdrop"
start = [20.0, -10.0]
end = [20.0, 10.0]
height_m = 5.0
texture = { kind = "square_grating", period_m = 1.0, orientation_deg = 90.0, dark = 0.3, light = 0.7 }

[[world.projectiles]]
name = "ball"
radius_m = 0.2
target = "camera"
launch_distance_m = 6.0
speed_mps = 12.0
texture = { kind = "uniform", luminance = 0.05 }
"""


@pytest.fixture
def short_toml() -> str:
    return SHORT_SCENARIO


@pytest.fixture
def short_kwargs(short_toml: str) -> dict:
    return {"scenario_toml": short_toml, "frame_size": 32}
