"""The brushes (issue 11): today's round stamp brush and the deformable spine brush.

Modules: ``stamp`` (the round stamp brush and the ``brush`` command's
settings), ``spine`` (kinematic chains), ``energy`` and ``solver`` (static
equilibrium with NLopt), ``geometry`` (shape files and the FFD tuft),
``footprint`` (+ ``footprint_gl``), ``reservoir`` (paint both ways) and
``deformable`` (pen → brush → sources).
"""
