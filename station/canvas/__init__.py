"""The canvas model: the three-layer watery-paint state and its physics (WaterVerve,
seed chapters 4 and 6).

``state`` (the arrays), ``params`` / ``profiles`` / ``palette`` / ``paper`` (what a
painting is made of), ``tiles`` (the active-tile bookkeeping), ``reference`` (the
numpy pass list every backend implements), ``operations`` and ``removal`` (what
sources, the hair dryer and the brush's pick-up do to a state). Backends live in
:mod:`station.backends`, rendering in :mod:`station.render`.
"""
