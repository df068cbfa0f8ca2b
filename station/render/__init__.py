"""Rendering: a canvas state to a picture. ``km`` (Kubelka–Munk over spectral bands
and the gouache renderer), ``km_fast`` (the same colours compiled with numba, as the
kiosk draws every frame), ``upscale`` (a small simulation drawn at k pixels per cell)
and ``png`` (writing the picture)."""
