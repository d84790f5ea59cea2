"""Validation limits: what a scenario may ask for before e2esim answers with a message instead of work.

Every limit is a named constant here, in one place, with the reason for its value. A scenario beyond a
limit is refused by ``e2esim validate`` and ``e2esim run`` within a second or two, with exit status 2 and
a message naming the number, the limit and, where the work is legitimate, how to run it. The limits are
far above every shipped scenario (the largest has 1 200 cases, 122 dates and a few MB per case) and far
below what would exhaust a workstation.
"""

from __future__ import annotations

from e2esim.errors import ConfigError, LimitError, Location

MAX_DOCUMENT_BYTES = 1_000_000
"""A scenario file: 1 MB. The largest shipped scenario is 5 kB; a sweep that needs more text is better
written with ``linspace``/``logspace`` or split into several scenarios."""

MAX_NODES = 100_000
"""Values in a scenario after YAML aliases are expanded: 100 000. Stops "billion laughs" alias bombs,
which are small on disk and exponential in memory, before they are expanded."""

MAX_DEPTH = 100
"""Nesting of mappings and lists: 100 levels (a scenario needs about 5). Deeper documents would exhaust
Python's recursion limit in the YAML composer."""

MAX_CASES = 5_000_000
"""Sweep cases in one run: 5 million (a global 1-degree map over 12 months, 2 passes and 2 solar levels is
about 3 million). A sweep is kept in factored form (``e2esim.runner.sweep.SweepTable``) and its modules are
built once per distinct configuration; what grows with the cases is at most ``MEMORY_PER_CASE_BYTES`` per case
(2.4 GiB at the limit) beside a fixed part of a few hundred MB."""

MEMORY_PER_CASE_BYTES = 512
"""What a run of more than ``e2esim.runner.spill.SPILL_ABOVE_CASES`` cases grows by per case: at most 512 bytes in
the main process, and in all its processes together (``--workers``), for every requirement type, level margins
and trade-off curves included, and when resumed. Its finished blocks are on disk (``e2esim.runner.spill``): it
holds their case indices (8 bytes a case) and, while the outputs are written, a few of the run's columns at a
time. Beside it: the imports, the blocks in flight and the catalogs of distinct scenes, instruments and error
budgets, bounded by ``e2esim.runner.blocks.CATALOG_ENTRIES`` and ``e2esim.budget.block.BUDGET_CATALOG_ENTRIES``
(docs/architecture.md, "Memory is bounded by the blocks"). Measured by benchmarks/bench_memory.py; what a run
holds per case is checked by tests/test_memory_of_large_runs.py."""

MAX_MAP_CASES = 5_000_000
"""Cases of a map sweep (``sweep: {map: ...}``, e2esim.maps.grid), and cells of its grid: 5 000 000, as
``MAX_CASES``. A 1 deg global map of the forest cells (MODIS 2019) of the default latitude bands over 12 months
and 2 passes has about 119 000 cases (210 000 with every land cell of the bands), and every land cell over 12
months, 2 passes and 2 solar levels about 1 070 000. The batched engine keeps each case's results as columns,
on disk beyond ``SPILL_ABOVE_CASES`` cases (``MEMORY_PER_CASE_BYTES``); the per-case runner (``--per-case``)
would keep every case's products, about 45 kB a case: run large maps with the batched engine."""

MAX_DATES = 100_000
"""Acquisition dates of an orbit module: 100 000 (274 years at one date a day)."""

MAX_MONTE_CARLO_BYTES = 4 * 2**30
"""Memory one case's Monte Carlo may need, estimated from its sizes (``monte_carlo_bytes``): 4 GiB, so
that a few worker processes still fit a workstation. The Table II checks at the paper's sizes need 13 MB."""

MAX_STORED_SCENARIO_BYTES = 4 * MAX_DOCUMENT_BYTES
MAX_STORED_SCENARIO_VALUES = 2 * MAX_NODES
"""The scenario text stored in a results.h5 (``/provenance``), read back by ``e2esim compare`` and
``open_results``: the scenario limits, with room for the resolved form (every module's defaults filled in,
written one value a line), and checked the same way before anything is built (aliases counted expanded)."""

MAX_H5_DECOMPRESSED_BYTES = 2**30
"""Compressed data of one HDF5 file that e2esim reads (a results.h5 someone repacked with gzip; e2esim writes
none): 1 GiB once decompressed, each chunk never beyond its declared size. Uncompressed data is limited by
the file itself: every byte read must be stored in it (no fill values)."""

MAX_H5_CHUNKS = 100_000
"""Chunks of one compressed dataset: each is checked before HDF5 decompresses it (about 2 s at the limit)."""

MAX_JOURNAL_RECORD_BYTES = 16 * 2**30
"""One record of a resume journal (a finished block of cases, with its products when the run keeps them):
16 GiB. A block of the largest Monte Carlo with kept samples is far below; a record declaring more is
refused before it is read."""

MAX_MESSAGE_VALUE_CHARS = 80
"""A value quoted in an error message is cut to this many characters."""

SPLIT_ADVICE = ("split the sweep into several scenarios (for example one per value of its first key) and run "
                "them one after another or side by side, each with --workers N or --scheduler ADDRESS")


def check_count(what: str, count: float, limit: int, where: str, advice: str = "") -> None:
    """Raise ``LimitError`` if ``count`` (of ``what``) exceeds ``limit``; ``where`` starts the message."""
    if count > limit:
        shown = f"{count:.3g}" if count >= 1e15 else f"{int(count):,}"
        message = f"{where}: {shown} {what} exceed the limit of {limit:,}"
        raise LimitError(message + (f"; {advice}" if advice else ""))


def monte_carlo_bytes(looks: int, realisations: int, noise_realisations: int) -> float:
    """Estimated peak memory (bytes) of one case's Monte Carlo (``e2esim.distortion.montecarlo``).

    Per realisation and noise draw the simulation keeps the error of three channels plus temporaries (about
    24 doubles), per realisation the system errors and Faraday angles (about 32 doubles), and per look the
    scene vectors of the brute-force method (three complex values and their matrices, 16 doubles). A float
    estimate, so that absurd sizes (1e300) do not overflow.
    """
    m, n, looks = float(realisations), float(noise_realisations), float(looks)
    return 8.0 * (24.0 * m * n + 32.0 * m + 16.0 * looks)


def check_monte_carlo(settings, where: str) -> None:
    """Refuse a case whose Monte Carlo would need more than ``MAX_MONTE_CARLO_BYTES``."""
    if not getattr(settings, "montecarlo", False):
        return
    need = monte_carlo_bytes(settings.looks, settings.realisations, settings.noise_realisations)
    if need > MAX_MONTE_CARLO_BYTES:
        raise LimitError(
            f"{where}: the Monte Carlo of looks={settings.looks:g}, realisations={settings.realisations:g}, "
            f"noise_realisations={settings.noise_realisations:g} needs about {_size(need)} per case, above the "
            f"limit of {_size(MAX_MONTE_CARLO_BYTES)}; lower realisations or noise_realisations (the standard "
            "error of the Monte Carlo falls only as 1/sqrt(realisations)), or use mode: analytic"
        )


def _size(nbytes: float) -> str:
    for unit, scale in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if nbytes >= scale:
            value = nbytes / scale
            return f"{value:.3g} {unit}" if value < 1e6 else f"{value:.2e} {unit}"
    return f"{nbytes / 1024:.3g} KiB"


def shorten(text: str, limit: int = MAX_MESSAGE_VALUE_CHARS) -> str:
    """``text`` cut to ``limit`` characters (with a note of the full length), on one line."""
    text = " ".join(str(text).split("\n"))
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text):,} characters)"


def check_plain(value, where: Location) -> None:
    """Refuse what a scenario cannot hold, whether read from YAML or given from Python: mapping keys that
    are not text, nesting deeper than ``MAX_DEPTH`` and more than ``MAX_NODES`` values (a structure that
    contains itself never ends, so it hits the last limit). Iterative: deep data cannot exhaust the stack."""
    stack = [(value, (), 0)]
    seen = 0
    while stack:
        item, path, depth = stack.pop()
        seen += 1
        if seen > MAX_NODES:
            raise LimitError(f"{where.describe()}: the scenario holds more than the limit of {MAX_NODES:,} values")
        if isinstance(item, dict):
            children = list(item.items())
            for key, _ in children:
                if not isinstance(key, str):
                    raise ConfigError(Location(where.source, path + (key,), where.lines),
                                      f"the key {shorten(repr(key))} is {type(key).__name__}, not text",
                                      "keys must be text (in YAML, quote it)")
        elif isinstance(item, (list, tuple)):
            children = list(enumerate(item))
        else:
            continue
        if children and depth >= MAX_DEPTH:
            raise LimitError(f"{Location(where.source, path, where.lines).describe()}: mappings and lists are nested "
                             f"deeper than the limit of {MAX_DEPTH} levels")
        stack.extend((child, path + (key,), depth + 1) for key, child in children)
