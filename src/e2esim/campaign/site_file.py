"""A user's calibration sites in a YAML file (issue 25, item 1): ``sites:`` a list of mappings with the keys of
``e2esim.campaign.sites.SITE_KEYS``. Read with the size limit and checks of a user file; ``yaml.safe_load`` only."""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from e2esim.campaign.sites import site_from_mapping
from e2esim.errors import PhysicsInputError
from e2esim.input_files import open_regular, read_limited

MAX_BYTES = 1 << 20


def read_sites_file(path: Path, key: str) -> tuple:
    """The sites of a YAML file; a bad file or entry raises ``PhysicsInputError`` naming the file and the key path
    inside it (``key`` is the parameter that named the file)."""
    try:
        fd = open_regular(path, "calibration sites file", error=PhysicsInputError)
    except PhysicsInputError as exc:
        raise PhysicsInputError(str(exc), key=key) from None
    try:
        text = read_limited(fd, MAX_BYTES + 1)
    finally:
        os.close(fd)
    if len(text) > MAX_BYTES:
        raise PhysicsInputError(f"{path}: the calibration sites file is larger than {MAX_BYTES:,} bytes", key=key)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise PhysicsInputError(f"{path}: not valid YAML ({exc})", key=key) from None
    if not isinstance(data, dict) or not isinstance(data.get("sites"), list) or not data["sites"]:
        raise PhysicsInputError(f"{path}: expected a mapping with 'sites:', a non-empty list of sites", key=key)
    out = []
    for i, entry in enumerate(data["sites"]):
        try:
            out.append(site_from_mapping(entry, f"sites.{i}"))
        except PhysicsInputError as exc:
            raise PhysicsInputError(f"{path}: {exc.key}: {exc}", key=key) from None
    return tuple(out)
