"""What ``e2esim solve`` and ``e2esim allocate`` run (their parsers: ``e2esim.flowdown.parsers``)."""

from __future__ import annotations

from pathlib import Path

from e2esim.atomic import write_text_atomic
from e2esim.errors import UserError
from e2esim.flowdown.allocation import allocate, allocation_markdown, allocation_yaml
from e2esim.flowdown.answer import stated_solve
from e2esim.flowdown.inverse import solve
from e2esim.flowdown.report import solve_json, solve_lines, solve_markdown
from e2esim.runner.folder_run import check_executor
from e2esim.runner.scenario import Scenario


def _scenario(args):

    return Scenario.load(args.scenario, args.overrides, allow_imports=args.allow_import,
                         replace_sweep=args.replace_sweep)


def _write(folder, files: dict) -> None:

    if folder is None:
        return
    Path(folder).mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        write_text_atomic(Path(folder) / name, text)


def cmd_solve(args) -> int:

    scenario = _scenario(args)
    keys, one, worst = stated_solve(scenario.raw, args.keys, args.bounds, args.worst_case)
    if not keys:
        raise UserError(f"{args.scenario}: give --for KEY (or a 'solve: {{for: [KEY]}}' section in the scenario)")
    check_executor(args.workers, None)
    result = solve(scenario, keys, one, worst_case=worst, points=args.points, workers=args.workers)
    name = scenario.raw.get("name", Path(args.scenario).stem)
    _write(args.output, {"solve.md": solve_markdown(name, result), "solve.json": solve_json(result) + "\n"})
    if args.json:
        print(solve_json(result))
    else:
        print("\n".join(solve_lines(name, result)))
    return 0


def cmd_allocate(args) -> int:

    scenario = _scenario(args)
    weights = dict(_pair(w, "--weight", float) for w in args.weight)
    fixed = dict(_pair(f, "--fix", float) for f in args.fix)
    sources = dict(_pair(s, "--source", str) for s in args.source) or None
    result = allocate(scenario, args.requirement, args.split, weights, fixed, sources)
    name = scenario.raw.get("name", Path(args.scenario).stem)
    _write(args.output, {"specification.yaml": allocation_yaml(result), "specification.md":
                         allocation_markdown(name, result)})
    print(allocation_markdown(name, result), end="")
    return 0 if result.holds else 1


def _pair(text: str, option: str, kind):
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise UserError(f"{option} {text!r}: expected NAME=VALUE")
    try:
        return name.strip(), kind(value)
    except ValueError:
        raise UserError(f"{option} {text!r}: {value!r} is not a number") from None


