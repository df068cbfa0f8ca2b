"""The station's face of calibration: device access and the calibration window.

``station.calibration`` is pure maths and file formats: it takes pen samples
in and knows nothing of transports, windows or GL.  This package feeds it:

* :mod:`station.calibrate.sources` — where the calibration's pen samples come
  from (a drivers device SPEC through the drivers' pipeline, a simulated
  installer, replayed taps);
* :mod:`station.calibrate.samples` — pen samples of a recorded session log or
  device trace (``station calibrate --from-trace``);
* :mod:`station.calibrate.window` — the fullscreen glfw/moderngl window of
  ``station calibrate --device``.
"""
