"""Calibration and repeatability reports: Markdown with PNG figures (matplotlib, Agg canvas).

Import from the modules (`calibration_report`, `limits`, `metrics`, `repeatability`): the package itself loads
nothing, so reading the limits of a configuration does not load matplotlib.
"""
