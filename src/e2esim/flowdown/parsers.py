"""The parsers of the ``e2esim solve`` and ``e2esim allocate`` subcommands. Light to import: the command line builds
its parser from here; what a command runs (``e2esim.flowdown.commands``) is imported when it runs, as
``e2esim.__getattr__`` imports the API."""

from __future__ import annotations

import importlib


def add_parsers(sub, add_scenario_options) -> None:
    """Add ``solve`` and ``allocate`` to the subparsers ``sub``; ``add_scenario_options`` adds --set and the like."""
    solve = sub.add_parser(
        "solve", help="find the value of a key at which each requirement is exactly met",
        description="For every case (or the worst case over the sweep), the value of one numeric scenario key at which "
                    "each requirement is exactly met, the case that binds and the margins of the others; with two "
                    "keys, the boundary of the region where every requirement holds. Root finding through the "
                    "engine's analytic forward model. The keys and bounds may also come from the scenario's "
                    "'solve:' section ({for: [KEY, ...], bounds: [[LO, HI], ...], worst_case: true}).")
    solve.add_argument("scenario", help="scenario YAML file")
    solve.add_argument("--for", dest="keys", action="append", default=[], metavar="KEY",
                       help="the key to solve for, dotted as --set takes it (give it twice for a boundary of two keys)")
    solve.add_argument("--bounds", nargs=2, type=float, action="append", metavar=("LO", "HI"),
                       help="search range of each --for key, in its order (default: the parameter's allowed range)")
    solve.add_argument("--worst-case", action="store_true", help="one value per requirement: the worst case over "
                                                                  "the sweep (default: every case)")
    solve.add_argument("--points", type=int, default=100, help="points along a two-key boundary (default 100)")
    solve.add_argument("--workers", type=int, default=1, metavar="N", help="processes each engine run spreads its "
                                                                           "blocks over (the same answer as 1)")
    solve.add_argument("-o", "--output", metavar="DIR", help="also write solve.md and solve.json into DIR")
    solve.add_argument("--json", action="store_true", help="print the result as JSON")
    add_scenario_options(solve)

    allocate = sub.add_parser(
        "allocate", help="flow a requirement down to a specification of every source",
        description="Split requirement N's total among the sources of its error (equal or weighted shares of its "
                    "variance, some fixed), find the specification of each source's key, check it back through "
                    "the forward model over every case, and write a specification table (YAML a scenario can "
                    "include, and Markdown). Sources and keys: the scenario's 'allocate:' section, or --source.")
    allocate.add_argument("scenario", help="scenario YAML file")
    allocate.add_argument("--requirement", type=int, default=1, metavar="N", help="the requirement (1 the first)")
    allocate.add_argument("--split", choices=("equal", "weighted"), default="equal", help="how the total is split")
    allocate.add_argument("--weight", action="append", default=[], metavar="SOURCE=W", help="weight of a source "
                                                                                            "(--split weighted)")
    allocate.add_argument("--fix", action="append", default=[], metavar="KEY=VALUE",
                          help="keep this source key at VALUE; the others share what it leaves")
    allocate.add_argument("--source", action="append", default=[], metavar="SOURCE=KEY",
                          help="a source and the key that sets it (default: the scenario's allocate.sources)")
    allocate.add_argument("-o", "--output", metavar="DIR", help="write specification.yaml and specification.md "
                                                                "into DIR")
    add_scenario_options(allocate)


def _command(name: str):
    def run(args) -> int:
        return getattr(importlib.import_module("e2esim.flowdown.commands"), name)(args)
    return run


COMMANDS = {"solve": _command("cmd_solve"), "allocate": _command("cmd_allocate")}


def scenario_answer(resolved, workers: int = 1):
    """``e2esim.flowdown.answer.scenario_answer``, imported when ``e2esim run`` calls it."""
    return importlib.import_module("e2esim.flowdown.answer").scenario_answer(resolved, workers)
