"""The maps wing: map sweeps (``sweep: {map: ...}``), their results.nc and their report plots, together.

``grid``: the sweep section, its grid of forest cells and its cases (the wing's only door to the physics: the
land mask, the land cover, the scene's forest and the cells the ionosphere's orbit sees, asked of the modules'
public functions before any case runs). ``netcdf``: the map dataset of a run's results on that grid, and its
CF-1.8 NetCDF file. ``plots``: the report's maps and the share of the forest meeting each requirement, drawn from
that dataset. Nothing is imported here, so that a run without a map loads none of it.
"""
