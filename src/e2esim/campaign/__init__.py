"""The calibration campaign over the mission's life (issue 25; Quegan et al. 2018, Sections 4 and 5): calibration
sites, when the orbit sees them, what each visit measures, the drift between visits and the error left at every
date (docs/theory/calibration-campaign.md)."""
