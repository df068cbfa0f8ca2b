"""Artistic tools that act on the canvas state between steps (seed chapter 8): masking
fluid, the selective eraser and the textured tissue, one module each. Each is a one-off
operation on a :class:`~station.canvas.state.CanvasState` that books what it removes;
the session player runs it on any backend with
``station.backends.protocol.edit_state`` (in place on NumPy/cpu, through a
state round trip on GL)."""
