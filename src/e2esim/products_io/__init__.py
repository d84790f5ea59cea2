"""Real products read for a per-pixel error budget (issue 26): the BIOMASS L1 product of the BIOMASS
Processing Suite and the NISAR GCOV, RSLC and GSLC products. One file per concept: the layout of each product
(``biomass_layout``, ``nisar_layout``, ``nisar_slc_layout``: group and variable names, units and conventions, with
their sources), its reader (``biomass_l1``, ``nisar_gcov``, ``nisar_slc``; ``nisar_products`` tells which NISAR
product a file is), the pixels both readers hand on (``pixels``), the assumptions a product does not
hold (``assumptions``), the per-pixel model (``pixel_model``) and the uncertainty product (``uncertainty``,
``uncertainty_files``). docs/real-data.md says how to run it and what it reads and assumes."""
