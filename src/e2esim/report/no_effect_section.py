"""The report's section on settings that change nothing (``e2esim.runner.no_effect``): on the first screen, after
the verdicts, because a reader who swept a setting would otherwise read its flat curve as a finding."""

from __future__ import annotations

from e2esim.report.blocks import Heading, Paragraph
from e2esim.runner.no_effect import no_effect


def no_effect_section(result) -> list:
    findings = no_effect(result)
    if not findings:
        return []
    return [Heading(2, "Settings that change nothing")] + [Paragraph(f.message()) for f in findings] + [Paragraph(
        "A swept setting is compared between cases that differ in it alone, on every deterministic result after "
        "its stage; an override is reported when the value was already in force, when its module never read it, or "
        "when every stage that reads its stage's products cannot depend on it; a setting the scenario file gives is "
        "reported when its module never read it (docs/user-guide.md, \"Settings "
        "that change nothing\").")]
