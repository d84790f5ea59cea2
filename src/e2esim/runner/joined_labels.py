"""Case labels in factored form: per case, one code per group of sweep keys into a table of label parts.

A sweep's label names the keys that differ between cases (``e2esim.runner.sweep.case_labels``); in a grid each
group of keys contributes its own part, so a million labels are a few hundred distinct parts and a (cases,
groups) table of small integers. results.h5 stores them in this form (docs/output-format.md) and
``open_results`` reads them back as ``JoinedLabels``, which joins a label only when it is asked for.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

SEPARATOR = ", "
NO_PART = "base case"
"""The label of a case whose parts are all empty (a run without a sweep)."""


def numbered(label: str, index: int) -> str:
    """A label that another case shares, made unique by the case number."""
    return f"{label} (#{index})"


class JoinedLabels(Sequence):
    """Labels joined from parts: label i is ``", ".join`` of the non-empty ``parts[codes[i, g]]`` over groups g
    (``"base case"`` when all are empty), with ``" (#i)"`` appended where ``numbered[i]``.

    parts : (P,) the distinct part texts. codes : (n, G) integers into ``parts``. numbered : (n,) bool.
    """

    def __init__(self, parts, codes, numbered_cases):
        self.parts = np.asarray(list(parts) if not isinstance(parts, np.ndarray) else parts, dtype=object)
        self.codes = np.asarray(codes)
        self.numbered = np.asarray(numbered_cases, dtype=bool)

    @classmethod
    def of(cls, labels) -> JoinedLabels:
        """From finished labels: one group, each distinct label one part."""
        parts, codes = np.unique(np.asarray(list(labels), dtype=object), return_inverse=True)
        return cls(parts, codes.reshape(-1, 1), np.zeros(len(codes), dtype=bool))

    def __len__(self) -> int:
        return len(self.codes)

    def __getitem__(self, index):
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        index = range(len(self))[index]
        label = SEPARATOR.join(p for p in self.parts[self.codes[index]] if p) or NO_PART
        return numbered(label, index) if self.numbered[index] else label

    def __eq__(self, other) -> bool:
        return isinstance(other, Sequence) and not isinstance(other, str) and list(self) == list(other)

    __hash__ = None

    def tolist(self) -> list:
        """Every label, joined column by column (a million in about a second)."""
        n = len(self)
        columns = [self.parts[self.codes[:, g]] for g in range(self.codes.shape[1])]
        labels = ([SEPARATOR.join(p for p in row if p) or NO_PART for row in zip(*columns)] if columns
                  else [NO_PART] * n)
        for i in np.flatnonzero(self.numbered):
            labels[i] = numbered(labels[i], int(i))
        return labels


__all__ = ["JoinedLabels", "numbered"]
