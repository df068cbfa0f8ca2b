"""``station kiosk``: the live painting window a visitor paints on with a pen.

Modules: :mod:`.session` (the in-process simulation fed by the bus, one per
painting), :mod:`.display` (canvas → texture: dirty tiles on the CPU, the GPU
canvas's own texture on GL), :mod:`.views` (2D, 3D table, brush-following
camera; screen ↔ canvas), :mod:`.imgui_gl` (Dear ImGui drawn with moderngl),
:mod:`.ui` (the pen-only panel), :mod:`.idle` (attract screen, idle timeout),
:mod:`.gallery` (paintings on disk, the web page, QR codes, replay animations),
:mod:`.app` (the window and its frame loop).  See docs/kiosk.md.
"""
