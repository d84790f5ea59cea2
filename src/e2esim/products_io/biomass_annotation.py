"""The BIOMASS L1 annotation XML: what the per-pixel error budget needs from it (``e2esim.products_io.
biomass_layout`` gives the names and their source, the BPS XSDs)."""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET

import numpy as np

from e2esim.input_files import open_regular, read_limited
from e2esim.products_io import biomass_layout as layout
from e2esim.products_io.pixels import ProductFileError

MAX_ANNOTATION_BYTES = 64 * 2**20


def read_annotation(path) -> dict:
    """{crosstalk: complex (4,), imbalance: complex (2,), faraday_applied: bool, rfi_percent: {pol: %}}."""
    fd = open_regular(path, "BIOMASS annotation", ProductFileError)
    try:
        data = read_limited(fd, MAX_ANNOTATION_BYTES + 1)
    finally:
        os.close(fd)
    if len(data) > MAX_ANNOTATION_BYTES:
        raise ProductFileError(f"{path}: larger than {MAX_ANNOTATION_BYTES} bytes; not a BIOMASS L1 annotation")
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise ProductFileError(f"{path}: not a complete XML document ({exc}); a BIOMASS L1 annotation "
                               f"({layout.ANNOTATION_ROOT}) is expected") from None
    if _local(root.tag) != layout.ANNOTATION_ROOT:
        raise ProductFileError(f"{path}: root element {_local(root.tag)!r}; expected {layout.ANNOTATION_ROOT!r}")
    crosstalk = np.array([_complex(path, root, f"{layout.CROSSTALK_PATH}/{n}") for n in layout.CROSSTALK_ELEMENTS])
    imbalance = np.array([_complex(path, root, f"{layout.IMBALANCE_PATH}/{n}")
                          for n in layout.IMBALANCE_ELEMENTS])
    applied_text = _text(path, root, layout.FARADAY_APPLIED_PATH)
    if applied_text not in layout.BOOLEAN_TEXT:
        raise ProductFileError(f"{path}: {layout.FARADAY_APPLIED_PATH}: {applied_text!r}; expected 'true' or 'false'")
    rfi = {}
    for report in _find_all(root, layout.RFI_REPORT_PATH):
        pol = report.get("polarisation", "?")
        rfi[pol] = _number(path, report, layout.RFI_FRACTION_ELEMENT,
                           f"{layout.RFI_REPORT_PATH}[@polarisation={pol}]/{layout.RFI_FRACTION_ELEMENT}")
        if not 0.0 <= rfi[pol] <= 100.0:
            raise ProductFileError(f"{path}: {layout.RFI_REPORT_PATH}/{layout.RFI_FRACTION_ELEMENT} ({pol}): "
                                   f"{rfi[pol]!r}; a percentage in [0, 100] is expected")
    return {"crosstalk": crosstalk, "imbalance": imbalance,
            "faraday_applied": layout.BOOLEAN_TEXT[applied_text], "rfi_percent": rfi}


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _find_all(root, path: str) -> list:
    nodes = [root]
    for part in path.split("/"):
        nodes = [c for n in nodes for c in n if _local(c.tag) == part]
    return nodes


def _element(path, root, where: str):
    found = _find_all(root, where)
    if not found:
        raise ProductFileError(f"{path}: element {layout.ANNOTATION_ROOT}/{where} is missing; the BIOMASS L1 "
                               "annotation (bio-l1-annotations.xsd) has it")
    return found[0]


def _text(path, root, where: str) -> str:
    return (_element(path, root, where).text or "").strip()


def _number(path, node, child: str, where: str) -> float:
    found = [c for c in node if _local(c.tag) == child]
    text = (found[0].text or "").strip() if found else None
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise ProductFileError(f"{path}: {where}: {text!r}; a finite number is expected") from None
    if not np.isfinite(value):
        raise ProductFileError(f"{path}: {where}: {text!r}; a finite number is expected")
    return value


def _complex(path, root, where: str) -> complex:
    node = _element(path, root, where)
    return complex(_number(path, node, "re", f"{where}/re"), _number(path, node, "im", f"{where}/im"))
