"""The ``simulation`` section of a scenario as the chain sees it: what to compute and the Monte Carlo sizes.

Each setting is declared once, as a field of ``SimulationSettings`` that carries its ``Param`` (type, bounds,
default, doc): ``SIMULATION_PARAMS`` is read from the fields, and the scenario validates the section with it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from e2esim.params import Param

MODES = ("analytic", "montecarlo", "both")
SEED_MAX = 2**64 - 1
"""The largest root seed: numpy's SeedSequence takes any integer, but results.h5 stores the seed as an unsigned
64-bit integer (HDF5 has no larger one)."""


def _setting(name: str, type_: str, doc: str, **kwargs):
    """A field with the default of its parameter, which it carries (``SIMULATION_PARAMS``)."""
    param = Param(name, type_, doc, **kwargs)
    return field(default=param.default, metadata={"param": param})


@dataclass(frozen=True)
class SimulationSettings:
    """The ``simulation`` section: what to compute and with which Monte Carlo sizes (each field's parameter says
    what it is: ``SIMULATION_PARAMS``)."""

    mode: str = _setting("mode", "str", "what to compute: analytic moments, Monte Carlo, or both", default="both",
                         choices=MODES)
    seed: int = _setting("seed", "int", "root seed of all random draws (case i uses SeedSequence(seed, "
                         "spawn_key=(i,))); at most 2^64 - 1, the largest integer results.h5 stores", default=0,
                         minimum=0, maximum=SEED_MAX)
    stream: int | None = _setting("stream", "int", "spawn key of the case's random draws: SeedSequence(seed, "
                                  "spawn_key=(stream,)) instead of the case's index; null (default): the index. "
                                  "Cases with the same seed and stream draw the same numbers (common random "
                                  "numbers, as output.sensitivity uses them)", default=None, nullable=True,
                                  minimum=0, maximum=SEED_MAX)
    looks: int = _setting("looks", "int", "L: independent pixels averaged into one sigma estimate (Men et al. "
                          "2021, eq. 17)", default=100_000, minimum=1)
    realisations: int = _setting("realisations", "int", "M: system-error and Faraday-rotation realisations",
                                 default=10_000, minimum=2)
    noise_realisations: int = _setting("noise_realisations", "int", "N: noise realisations per system-error "
                                       "realisation", default=1, minimum=1)
    keep_samples: bool = _setting("keep_samples", "bool", "store the Monte Carlo error samples in results.h5",
                                  default=True)

    def stream_of(self, index: int) -> int:
        """The spawn key of case ``index``'s generator: ``stream`` where set, else the index."""
        return int(index) if self.stream is None else int(self.stream)

    @property
    def analytic(self) -> bool:
        return self.mode in ("analytic", "both")

    @property
    def montecarlo(self) -> bool:
        return self.mode in ("montecarlo", "both")


SIMULATION_PARAMS = tuple(f.metadata["param"] for f in fields(SimulationSettings))
"""The ``simulation`` section's parameters, from the fields of ``SimulationSettings``."""
