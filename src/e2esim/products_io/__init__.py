"""Real products read for a per-pixel error budget (issue 26): the BIOMASS L1 product of the BIOMASS
Processing Suite and the NISAR GCOV product. One file per concept: the layout of each product (``biomass_layout``,
``nisar_layout``: group and variable names, units and conventions, with their sources), its reader
(``biomass_l1``, ``nisar_gcov``), the pixels both readers hand on (``pixels``), the assumptions a product does not
hold (``assumptions``), the per-pixel model (``pixel_model``) and the uncertainty product (``uncertainty``,
``uncertainty_files``). docs/real-data.md says how to run it and what it reads and assumes."""
