"""GL plumbing shared by the GL canvas backend, the brush's GL footprint and the
tests: a headless or windowed moderngl context (``context``) and the shader library
that compiles the programs of ``shaders/`` (``shaderlib``). It knows nothing of the
canvas, so the brush can use it without reaching the canvas model."""
