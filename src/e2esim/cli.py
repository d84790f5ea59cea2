"""The ``e2esim`` command line: run, validate, modules, reproduce, compare.

User errors (bad scenario, bad argument) print one clear message and exit with status 2, without a
traceback; ``--debug`` shows the traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import gc
import json
import os
import sys
import warnings

import e2esim
from e2esim.allocator import keep_freed_memory
from e2esim.errors import E2ESimWarning, UserError, one_line
from e2esim.flowdown import parsers as flowdown
from e2esim.products_io import parsers as products_commands
from e2esim.runner.interrupts import RunInterrupted

EXAMPLES = """examples:
  e2esim run scenarios/biomass_default.yaml
  e2esim run scenarios/biomass_default.yaml -o runs/test --force --set instrument.crosstalk.level_db=-28
  e2esim run scenarios/biomass_latitude_sweep.yaml --replace-sweep ionosphere.solar=max
  e2esim validate scenarios/men2021_table2.yaml
  e2esim modules instrument
  e2esim reproduce men2021 --json
  e2esim compare runs/biomass_default runs/crosstalk_28
  e2esim solve scenarios/biomass_default.yaml --for instrument.nesz_db --worst-case
  e2esim allocate scenarios/biomass_allocation.yaml --requirement 1 --split equal
"""


COMMAND_GC_THRESHOLD = 10_000
"""The garbage collector's youngest-generation threshold in the command line's own process (``main``)."""


@functools.lru_cache(maxsize=1)
def build_parser() -> argparse.ArgumentParser:
    """The command-line parser (built once per process: parsing does not change it)."""
    return _build_parser()


def _build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="e2esim",
        description="End-to-end mission performance simulator for spaceborne polarimetric SAR biomass missions.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"e2esim {e2esim.__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks for user errors too")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    run = sub.add_parser("run", help="run a scenario and write its outputs",
                         description="Run every case of a scenario through its chain of modules and write "
                                     "results.h5, summary.json, report.md and PNG plots into the output folder.")
    run.add_argument("scenario", help="scenario YAML file")
    run.add_argument("-o", "--output", metavar="DIR", help="output folder (default: output.folder, else runs/<name>)")
    run.add_argument("--force", action="store_true",
                     help="use an existing output folder: set the outputs and journal of the run that was there "
                          "aside, and remove them once the new outputs are complete (other files stay); a folder "
                          "where a run is live is still refused")
    _add_scenario_options(run)
    run.add_argument("--json", action="store_true", help="also print summary.json to stdout")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--workers", type=_workers, default="auto", metavar="N",
                     help="run sweep cases on N local processes, or 'auto' (the default): the first block in this "
                          "process, the rest on as many processes as there are usable cores when it is estimated "
                          "above 2 s (E2ESIM_AUTO_WORKERS_ABOVE_S); the same numbers either way")
    run.add_argument("--scheduler", metavar="ADDRESS",
                     help="run sweep cases on the dask.distributed cluster at ADDRESS (e.g. tcp://host:8786)")
    run.add_argument("--resume", action="store_true",
                     help="continue an interrupted run in the output folder without recomputing finished cases")
    run.add_argument("--per-case", action="store_true",
                     help="run the cases one at a time (the per-case runner: the reference the batched engine is "
                          "checked and timed against; the same numbers, much slower for large sweeps)")

    val = sub.add_parser("validate", help="check a scenario completely without running it",
                         description="Read and check a scenario: every section, key, value, module type and sweep "
                                     "case. Exit status 0 if valid, 2 with a message naming the problem if not.")
    val.add_argument("scenario", help="scenario YAML file")
    _add_scenario_options(val)

    mods = sub.add_parser("modules", help="list registered modules and their parameters",
                          description="List the modules registered through the entry-point group e2esim.modules "
                                      "(built-in and third-party), with their parameters.")
    mods.add_argument("kind", nargs="?", help="only this kind (orbit, ionosphere, scene, instrument, ...)")
    mods.add_argument("--json", action="store_true", help="machine-readable output")

    rep = sub.add_parser("reproduce", help="check e2esim against published results",
                         description="Recompute published numbers from the seed papers and compare. Each record "
                                     "has id, quantity, published, computed, tolerance, status (reproduced; "
                                     "low_power: consistent, but the tolerance is not smaller than the effect "
                                     "measured, so not counted as reproduced; discrepancy; failed), effect, "
                                     "power, citation and note.")
    rep.add_argument("sources", nargs="*", metavar="SOURCE", help="only these sources or ids (e.g. men2021)")
    rep.add_argument("--json", action="store_true", help="print the records as a JSON list")
    rep.add_argument("--report", metavar="FILE", help="write a markdown verification report to FILE")

    cmp = sub.add_parser("compare", help="show what differs between two runs",
                         description="Compare two runs (their folders or results.h5 files): the resolved scenarios, "
                                     "the verdicts and every output number of the cases they share. Prints the "
                                     "differences and writes them as a Markdown report. Exit status 0 when the runs "
                                     "agree, 1 when they differ.")
    cmp.add_argument("run_a", metavar="RUN_A", help="first run: output folder or results.h5")
    cmp.add_argument("run_b", metavar="RUN_B", help="second run: output folder or results.h5")
    cmp.add_argument("--report", metavar="FILE", default="comparison.md",
                     help="Markdown report to write (default: comparison.md in the working directory)")
    cmp.add_argument("--rtol", type=float, default=1e-9, metavar="R",
                     help="relative difference below which two numbers agree (default 1e-9)")
    flowdown.add_parsers(sub, _add_scenario_options)
    products_commands.add_parser(sub)
    return parser


def _add_scenario_options(sub) -> None:
    """The options that change the scenario: the same for run and validate, applied the same way."""
    sub.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scenario value by dotted key, e.g. instrument.nesz_db=-30 (repeatable); "
                          "a key the sweep sets is an error: change the sweep with --set sweep.parameters.KEY=[...] "
                          "or --set sweep.cases.I.KEY=VALUE, or use --replace-sweep")
    sub.add_argument("--replace-sweep", dest="replace_sweep", action="append", default=[], metavar="KEY=VALUE",
                     help="take KEY out of the sweep and give it VALUE in every case (repeatable)")
    sub.add_argument("--allow-import", dest="allow_import", action="append", default=[], metavar="PACKAGE",
                     help="let 'type: PACKAGE.module:Class' import PACKAGE although it is not an installed "
                          "distribution (repeatable; the working directory is never searched; docs/security.md)")


def main(argv=None) -> int:
    """Run the command ``argv`` (None: the process's own command line, ``sys.argv[1:]``); return its exit status."""
    if argv is None:  # the process's own command line: the collector runs its youngest generation every
        # COMMAND_GC_THRESHOLD allocations instead of 700 (biomass_default: 22 collections instead of 330 and 0.1 s
        # of CPU less; the cycles a run leaves are few and freed a little later, nothing else changes)
        gc.set_threshold(COMMAND_GC_THRESHOLD, *gc.get_threshold()[1:])
    status = _command(argv)
    if argv is None:  # the process's own command line: the process ends next
        gc.freeze()  # leave the objects it made to the OS: atexit handlers run and every object whose count drops
        # is still freed, but reference cycles are no longer searched while the interpreter tears itself down (0.3 s
        # of CPU after biomass_default's 100,000 objects and 1,100 modules), so a cycle's finalizer does not run;
        # every output is written and closed before this point
    return status


def _command(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    keep_freed_memory()
    try:
        with _plain_warnings():
            return COMMANDS[args.command](args)
    except UserError as exc:
        if args.debug:
            raise
        print(f"e2esim: error: {one_line(exc)}", file=sys.stderr)
        return exc.exit_status
    except RunInterrupted as stop:  # says what the run kept and how to go on
        print(f"e2esim: {stop.message}", file=sys.stderr)
        return stop.exit_status
    except KeyboardInterrupt:
        print("e2esim: interrupted; no partial output files were left", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return _broken_pipe()


@contextlib.contextmanager
def _plain_warnings():
    """e2esim's own warnings (``E2ESimWarning``: a cache it cannot use, a plug-in it cannot load) as one line on
    stderr, ``e2esim: warning: ...``, instead of Python's file-and-line form; other warnings as Python shows them."""
    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, E2ESimWarning):
            print(f"e2esim: warning: {one_line(str(message))}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = shown


def _broken_pipe() -> int:
    """The reader of our output went away (``e2esim modules | head -1``): stop quietly, as Unix tools do.
    stdout is pointed at /dev/null so that the interpreter's final flush cannot complain either."""
    with contextlib.suppress(OSError, ValueError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return 0


def _workers(text: str):
    """``--workers``: a whole number (checked by ``check_executor``) or auto."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a number of processes >= 1, or auto") from None


def _scenario(args):
    from e2esim.runner.scenario import Scenario

    return Scenario.load(args.scenario, args.overrides, allow_imports=args.allow_import,
                         replace_sweep=args.replace_sweep)


def validity_warnings(result, shown: int = 3) -> list:
    """Lines warning of cases whose analytic numbers come from a model used beyond its measured validity range
    (case notes beginning with ``distortion.modules.VALIDITY_NOTE``): the first ``shown`` notes and a count."""
    import numpy as np

    from e2esim.distortion.modules import VALIDITY_NOTE

    notes = result.table.notes
    counts = np.bincount(notes.index, minlength=len(notes.values))
    per_note: dict = {}
    for value, count in zip(notes.values, counts):
        for note in value:
            if note.startswith(VALIDITY_NOTE):
                per_note[note] = per_note.get(note, 0) + int(count)
    if not per_note:
        return []
    total = sum(per_note.values())
    lines = [f"{total} case(s) use an analytic model beyond its validity range (docs/theory/validity.md):"]
    lines += [f"  {count} case(s): {note}" for note, count in list(per_note.items())[:shown]]
    if len(per_note) > shown:
        lines.append(f"  ... and {len(per_note) - shown} more such notes (see the report)")
    return lines


def cmd_run(args) -> int:
    from e2esim.io.summary import summary_json
    from e2esim.report.document import verdict_lines
    from e2esim.runner.folder_run import check_executor, run_into_folder
    from e2esim.runner.no_effect import no_effect
    from e2esim.runner.outputs import output_folder

    check_executor(args.workers, args.scheduler, auto=True)
    resolved = _scenario(args).resolve()
    folder = output_folder(resolved, args.output)
    result = run_into_folder(resolved, folder, args.force, args.resume, progress=not args.no_progress,
                             command=" ".join(["e2esim"] + sys.argv[1:]), workers=args.workers,
                             scheduler=args.scheduler, engine="per_case" if args.per_case else "batched",
                             answer=lambda r: flowdown.scenario_answer(r, 1 if args.workers == "auto" else
                                                                       args.workers))
    for finding in no_effect(result):
        print(f"e2esim: warning: {finding.message()}", file=sys.stderr)
    out = sys.stderr if args.json else sys.stdout
    print(f"{resolved.name}: {len(result.cases)} case(s); outputs in {folder}/", file=out)
    for line in (result.answer or {}).get("lines", []):  # the scenario's own question first
        print("  answer: " + line.strip(), file=out)
    for line in verdict_lines(result) or ["(no requirements stated)"]:
        print("  " + line, file=out)
    for line in validity_warnings(result):
        print(f"e2esim: warning: {line}", file=sys.stderr)
    if args.json:
        print(summary_json(result))
    return 0


def cmd_validate(args) -> int:
    resolved = _scenario(args).resolve()
    case = resolved.cases[0]
    modules = ", ".join(f"{m.kind}={m.type_name}" for m in case.modules)
    products = " -> ".join("+".join(p.name for p in stage.provides) for stage in case.chain)
    print(f"{args.scenario}: valid; {len(resolved.cases)} case(s); modules: {modules}; products: {products}")
    return 0


def cmd_modules(args) -> int:
    from e2esim import registry
    from e2esim.docs_reference import module_records

    kinds = registry.kinds()
    if args.kind is not None and args.kind not in kinds:
        raise UserError(f"unknown module kind {args.kind!r}; kinds: {', '.join(kinds)}")
    records = module_records(registry.available(args.kind))
    if args.json:
        print(json.dumps(records, indent=2, default=str))
        return 0
    for rec in records:
        print(f"{rec['kind']}.{rec['type']}  ({rec['distribution']})  {rec['summary']}")
        for p in rec["parameters"]:
            default = "" if p["required"] else f" = {p['default']!r}"
            unit = f" [{p['unit']}]" if p["unit"] else ""
            print(f"    {p['name']}{unit}{default}: {p['doc']}; {p['allowed']}")
    for plugin in registry.broken_plugins():
        if args.kind is None or plugin.name.partition(".")[0] == args.kind:
            print(f"{plugin.name}  ({plugin.distribution})  NOT AVAILABLE: {plugin.problem}")
    return 0


def cmd_reproduce(args) -> int:
    from e2esim.verification.reproduce import render_report, run_checks, status_counts

    records = run_checks(args.sources)
    if args.report:
        from e2esim.atomic import write_text_atomic

        write_text_atomic(args.report, render_report(records))
    if args.json:
        print(json.dumps([r.as_dict() for r in records], indent=2))
    else:
        width = max((len(r.id) for r in records), default=10)
        for r in records:
            print(f"{r.status:12s} {r.id:{width}s} published {r.published:<10g} computed {r.computed:<12.5g} "
                  f"tol {r.tolerance:<9.3g} effect {r.effect:<9.3g} power {r.power:.2f}")
        print(f"{len(records)} checks: {status_counts(records)} (low_power: consistent, but the tolerance is not "
              "smaller than the effect, so the check cannot tell the published value from the null; see the note "
              "in --json)")
    return 0 if all(r.status != "failed" for r in records) else 1


def cmd_compare(args) -> int:
    from e2esim.api import open_results
    from e2esim.atomic import write_text_atomic
    from e2esim.compare import compare_report
    from e2esim.errors import OutputFolderError

    if not args.rtol >= 0:
        raise UserError(f"--rtol {args.rtol}: expected a relative tolerance >= 0")
    text, differ = compare_report(open_results(args.run_a), open_results(args.run_b), args.run_a, args.run_b,
                                  args.rtol)
    try:
        write_text_atomic(args.report, text + "\n")
    except OSError as exc:
        raise OutputFolderError(f"--report {args.report}: cannot write the comparison there: "
                                f"{exc.strerror or exc}; give a writable file with --report FILE") from exc
    print(text)
    print(f"(written to {args.report})")
    return 1 if differ else 0


COMMANDS = {"run": cmd_run, "validate": cmd_validate, "modules": cmd_modules, "reproduce": cmd_reproduce,
            "compare": cmd_compare, **flowdown.COMMANDS,
            **products_commands.COMMANDS}
