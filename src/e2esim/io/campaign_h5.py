"""The calibration campaign in results.h5 (issue 25): group ``campaign`` with the residual of every parameter on
every date, the visits, and the schedule search, written from the first case whose calibration record carries a
campaign (every case of one run shares it: only ``epoch_day`` differs between them). docs/output-format.md."""

from __future__ import annotations

import json

import numpy as np

from e2esim.io.h5_datasets import put, put_text
from e2esim.units import level_db_from_variance


def campaign_outcome(cases):
    """The ``CampaignOutcome`` of the first case that has one, or None."""
    for c in cases:
        record = c.get("calibration")
        for res in getattr(record, "results", ()) or ():
            if getattr(res, "outcome", None) is not None:
                return res.outcome
    return None


def write_campaign(f, cases) -> None:
    out = campaign_outcome(cases)
    if out is None:
        return
    g = f.create_group("campaign")
    r, s = out.result, out.search
    put(g, "day", r.days, "d", "mission day of each residual (day 0: the mission start, 00:00 UTC)")
    for p, about in (("crosstalk", "residual crosstalk level"), ("imbalance", "residual channel-imbalance level")):
        put(g, f"residual_{p}_db", level_db_from_variance(r.variance[p], out.convention), "dB",
            f"{about} on each day ({out.convention})")
    put(g, "residual_gain_sd_db", np.sqrt(r.variance["gain"]), "dB", "residual gain SD on each day (a pixel anywhere "
        "in the swath)")
    for part, about in (("gain_offset", "swath-mean gain"), ("pointing", "antenna pointing (dB at the far edge)"),
                        ("pattern", "antenna elevation pattern (dB at the far edge)")):
        if part in r.variance:
            put(g, f"residual_{part}_sd_db", np.sqrt(r.variance[part]), "dB", f"residual SD of the {about} on each day")
    put(g, "margin_db", out.margin, "dB", "smallest margin of the residuals against their limits on each day "
        "(inf in commissioning)")
    acq = r.acquisitions
    put_text(g, "site_names", list(out.site_names), "the calibration sites, in the order site codes count them")
    put(g, "visit_day", acq.day, "d", "mission day of every pass over a site")
    put(g, "visit_site", acq.site.astype(np.int32), "1", "site of every pass (position in site_names)")
    put(g, "visit_incidence_deg", np.degrees(acq.incidence), "deg", "incidence of every pass")
    if acq.faraday_rad is not None:
        put(g, "visit_faraday_deg", np.degrees(acq.faraday_rad), "deg", "Faraday rotation of every pass from the "
            "climatology (IRI monthly median, IGRF)")
        put(g, "visit_faraday_residual_sd_deg", np.degrees(np.sqrt(acq.faraday_residual_variance)), "deg",
            "SD of the Faraday rotation left by every pass's correction (estimator, ambiguity, scintillation)")
        put(g, "visit_log10_ckl", acq.log10_ckl, "1", "log10 of the scintillation strength C_kL (SI) of every pass")
    put(g, "visit_used", r.used.astype(np.int8), "1", "1 where the stated schedule used the pass")
    put(g, "schedule_transponder_per_year", s.per_year.astype(np.int32), "1",
        "schedule search: transponder passes per year after commissioning of each schedule tried")
    put_text(g, "schedule_opportunity", [json.dumps(list(o)) for o in s.opportunity],
             "schedule search: the targets of opportunity of each schedule tried (JSON list)")
    put(g, "schedule_margin_db", s.margin_db, "dB", "schedule search: smallest margin after commissioning")
    g.attrs["schedule_answer"] = -1 if s.best is None else int(s.best)
