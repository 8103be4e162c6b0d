"""Every example configuration shipped in config/ loads with the loader its recipe uses."""

from pathlib import Path

import pytest
import yaml

from boat_twin.cable.case import load_case
from boat_twin.config import TwinConfig, load_twin_config
from boat_twin.io.mavlink import load_calibration
from boat_twin.link.mavlink_boat import servo_calibration

CONFIG = Path(__file__).resolve().parents[1] / "config"
LOADERS = {
    "config": lambda path: load_twin_config(path, None, None),  # --config of simulate / diagnose
    "cable": load_case,  # cable --case
    "mavlink": load_calibration,  # --calibration of identify / diagnose / convert
}
"""Directory of config/ → the loader of its files."""
SHIPPED = sorted(CONFIG.rglob("*.yaml"))


def test_config_holds_examples_for_every_recipe() -> None:
    names = {path.relative_to(CONFIG).as_posix() for path in SHIPPED}
    assert {"boat.yaml", "cable/default.yaml", "mavlink/twin.yaml", "mavlink/ardupilot_two_outboards.yaml"} <= names
    assert {path.parent.name for path in SHIPPED} <= set(LOADERS), "a config/ directory without a loader here"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.relative_to(CONFIG).as_posix() for p in SHIPPED])
def test_shipped_config_loads(path: Path) -> None:
    assert LOADERS[path.parent.name](path) is not None


def test_twin_calibration_is_the_twins_own_servo_layout_for_the_default_boat() -> None:
    """config/mavlink/twin.yaml (the MAVLink recipe's --calibration) is what the link writes for config/boat.yaml."""
    shipped = yaml.safe_load((CONFIG / "mavlink" / "twin.yaml").read_text())["commands"]
    assert shipped == servo_calibration(TwinConfig().vessel)["commands"]
    assert shipped == servo_calibration(load_twin_config(CONFIG / "boat.yaml", None, None).vessel)["commands"]
