"""DEM regression and acceptance test harness (dissertation ch. 4).

The harness never imports the bundled engine: every DEM code, ours included, is run as a program.
"""
