"""Values a scenario takes from a real product instead of a climatology or a preset (issue 26, item 5): the layers
of a BIOMASS L1 product's LUT and the figures of its annotation at one pixel (a site, the scene centre or a map
sweep's cell). ``biomass_site`` reads them (physics layer: no output, no runner); ``modules`` holds the module types a
scenario names (Faraday rotation, noise, the budget's geometry, RFI), ``tec_modules`` the TEC's and
``distortion_modules`` the annotation's polarimetric distortion. docs/real-data.md, "A scenario driven by a
product"."""
