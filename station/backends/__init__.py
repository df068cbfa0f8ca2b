"""Canvas backends: one :class:`~station.backends.factory.CanvasBackend` protocol and
one factory (:func:`~station.backends.factory.create_backend`) over the numpy
reference (``numpy_canvas``), the numba ``cpu`` backend, the GL backend and the
distributed canvas over MPI. Every backend runs the model of :mod:`station.canvas`."""
