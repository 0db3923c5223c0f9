"""The robot registry of ``robots/registry.yaml``."""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from taskspace.errors import ModelLoadError, UnknownNameError

ROBOTS_DIR = Path(__file__).resolve().parents[3] / "robots"


@dataclass(frozen=True, kw_only=True)
class RobotSpec:
    """One registry entry (see the comments at the top of ``robots/registry.yaml``)."""

    name: str
    source: str
    description: str = ""
    erd_name: str | None = None
    urdf: Path | None = None
    free_flyer: bool = False
    end_effectors: tuple[str, ...] = ()
    locked_joints: tuple[str, ...] = ()
    default_posture: dict[str, Any] = field(default_factory=dict)


def _robots_dir() -> Path:
    if (ROBOTS_DIR / "registry.yaml").is_file():
        return ROBOTS_DIR
    raise ModelLoadError(
        f"robot registry not found at {ROBOTS_DIR / 'registry.yaml'}; install taskspace from its "
        "source tree (pip install -e .)"
    )


@lru_cache(maxsize=1)
def registry() -> dict[str, RobotSpec]:
    """All registry entries by name."""
    root = _robots_dir()
    with open(root / "registry.yaml") as f:
        raw = yaml.safe_load(f)
    specs: dict[str, RobotSpec] = {}
    for name, entry in raw.items():
        source = entry.get("source")
        if source not in ("example-robot-data", "urdf"):
            raise ModelLoadError(f"registry entry '{name}': unknown source {source!r}")
        specs[name] = RobotSpec(
            name=name,
            source=source,
            description=entry.get("description", ""),
            erd_name=entry.get("name"),
            urdf=(root / entry["urdf"]) if "urdf" in entry else None,
            free_flyer=bool(entry.get("free_flyer", False)),
            end_effectors=tuple(entry.get("end_effectors", ())),
            locked_joints=tuple(entry.get("locked_joints", ())),
            default_posture=dict(entry.get("default_posture") or {}),
        )
    return specs


def robot_spec(name: str) -> RobotSpec:
    """The registry entry called ``name``; lists the valid names if it does not exist."""
    specs = registry()
    if name not in specs:
        raise UnknownNameError("robot", name, specs)
    return specs[name]
