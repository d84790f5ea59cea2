"""Print the requirements an optional extra of the installed e2esim adds to its core, one per line (``make test``).

``make test`` after ``make demo``: e2esim and its core are installed from this pyproject.toml, so installing
``-e ".[test]"`` would build e2esim's editable wheel a second time (in a fresh build environment) only to install
these. Read from the installed metadata, following the extras that name other extras (test -> all -> maps, ...).
Exit status 1, printing nothing, when a requirement has a marker other than ``extra == "..."``: the Makefile then
installs ``-e ".[EXTRA]"`` as before.
"""

from __future__ import annotations

import re
import sys
from importlib.metadata import PackageNotFoundError, requires

_EXTRA = re.compile(r'^extra\s*==\s*"([^"]+)"$')
_SELF = re.compile(r"^e2esim\s*\[([^\]]*)\]$")


def extra_requirements(extra: str) -> list[str] | None:
    """The requirements of ``extra`` and of the extras it names, without e2esim itself; None if one cannot be read."""
    by_extra: dict[str, list[str]] = {}
    for line in requires("e2esim") or []:
        spec, _, marker = (part.strip() for part in line.partition(";"))
        if not marker:
            continue  # the core: installed already
        match = _EXTRA.match(marker)
        if match is None:
            return None
        by_extra.setdefault(match.group(1), []).append(spec)
    wanted, out, seen = [extra], [], set()
    while wanted:
        name = wanted.pop()
        if name in seen:
            continue
        seen.add(name)
        if name not in by_extra:
            return None
        for spec in by_extra[name]:
            self_reference = _SELF.match(spec)
            if self_reference:
                wanted.extend(e.strip() for e in self_reference.group(1).split(","))
            elif spec not in out:
                out.append(spec)
    return out


def main(argv: list[str]) -> int:
    try:
        specs = extra_requirements(argv[1] if len(argv) > 1 else "test")
    except PackageNotFoundError:
        specs = None
    if specs is None:
        return 1
    print("\n".join(specs))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
