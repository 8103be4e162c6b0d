"""The twin's whole configuration: vessel, environment and sensors, from one YAML file (config/boat.yaml)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

import yaml

from boat_twin.errors import InputError
from boat_twin.files import atomic_write_text, load_yaml
from boat_twin.model_error import ModelError, model_error_from_dict
from boat_twin.sensors.gnss import GnssConfig
from boat_twin.sensors.um7 import Um7Config
from boat_twin.vessel.environment import Environment
from boat_twin.vessel.params import VesselParams, load_params, params_from_dict, params_to_dict
from boat_twin.vessel.tow import TowConfig

SECTIONS = ("vessel", "environment", "gnss", "um7", "tow", "model_error")
"""Top-level keys of a twin configuration file."""


@dataclass(frozen=True)
class TwinConfig:
    """Everything a simulated sea trial needs besides the scenario and the seed."""

    vessel: VesselParams = field(default_factory=VesselParams)
    environment: Environment = field(default_factory=Environment)
    gnss: GnssConfig = field(default_factory=GnssConfig)
    um7: Um7Config = field(default_factory=Um7Config)
    tow: TowConfig | None = None
    """A towed body (extra surge drag), or None."""
    model_error: ModelError = field(default_factory=ModelError)
    """What this twin normally gets wrong (``identify`` measures it; zero when the file has no such section)."""


def _environment(data: Any, where: str) -> Environment:
    if data is None:
        return Environment()
    if not isinstance(data, dict):
        raise InputError(f"{where}: 'environment' must be a mapping")
    names = {f.name for f in fields(Environment)}
    for key, value in data.items():
        if key not in names:
            raise InputError(f"{where}: unknown environment field '{key}'")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"{where}: environment '{key}' must be a number, got {value!r}")
    try:
        return Environment(**{k: float(v) for k, v in data.items()})
    except InputError as err:
        raise InputError(f"{where}: {err}") from None


def config_from_dict(data: Any, where: str, base: TwinConfig | None = None) -> TwinConfig:
    """Build a configuration from plain data; absent sections keep ``base`` (default: the seed boat)."""
    base = base or TwinConfig()
    if data is None:
        return base
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a mapping with sections {', '.join(SECTIONS)}")
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise InputError(f"{where}: unknown section '{unknown[0]}' (expected {', '.join(SECTIONS)})")
    try:
        return TwinConfig(
            vessel=params_from_dict(data["vessel"], f"{where}: vessel", base.vessel) if "vessel" in data
            else base.vessel,
            environment=_environment(data["environment"], where) if "environment" in data else base.environment,
            gnss=GnssConfig.from_dict(data["gnss"]) if "gnss" in data else base.gnss,
            um7=Um7Config.from_dict(data["um7"]) if "um7" in data else base.um7,
            tow=TowConfig.from_dict(data["tow"], where) if data.get("tow") is not None else base.tow,
            model_error=model_error_from_dict(data["model_error"], where) if "model_error" in data
            else base.model_error,
        )
    except InputError as err:
        text = str(err)
        raise InputError(text if text.startswith(where) else f"{where}: {text}") from None


def load_config(path: Path, base: TwinConfig | None = None) -> TwinConfig:
    """Read a twin configuration file (any subset of the sections)."""
    return config_from_dict(load_yaml(path), str(path), base)


def config_to_dict(config: TwinConfig) -> dict[str, Any]:
    """Plain data that :func:`config_from_dict` reads back (the layout of config/boat.yaml)."""
    data: dict[str, Any] = {
        "vessel": params_to_dict(config.vessel),
        "environment": asdict(config.environment),
        "gnss": asdict(config.gnss),
        "um7": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config.um7).items()},
    }
    if config.tow is not None:
        data["tow"] = config.tow.to_dict()
    if not config.model_error.zero:
        data["model_error"] = config.model_error.to_dict()
    return data


def save_config(config: TwinConfig, path: Path, comment: str = "") -> None:
    """Write ``config`` as a twin configuration YAML (atomically); ``comment`` lines go on top."""
    header = "".join(f"# {line}\n" for line in comment.splitlines())
    atomic_write_text(path, header + yaml.safe_dump(config_to_dict(config), sort_keys=False))


def load_twin_config(config_path: Path | str | None = None, model_path: Path | str | None = None,
                     current_mps: tuple[float, float] | None = None) -> TwinConfig:
    """The twin from a config YAML (default: the built-in boat), then an identified model YAML over its vessel,
    then a water current (east, north; m/s) — later sources win."""
    config = load_config(Path(config_path)) if config_path else TwinConfig()
    if model_path:
        config = replace(config, vessel=load_params(Path(model_path), config.vessel))
    if current_mps is not None:
        config = replace(config, environment=replace(config.environment, current_east_mps=current_mps[0],
                                                     current_north_mps=current_mps[1]))
    return config
