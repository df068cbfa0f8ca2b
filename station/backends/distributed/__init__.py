"""The distributed canvas: one painting over the ranks of an MPI job (dissertation ch. 5).

``decomp`` splits the rows (no MPI); ``exchange`` moves field rectangles between
ranks; ``canvas.DistributedCanvas`` is the canvas backend protocol over MPI. mpi4py
is the optional ``mpi`` extra, imported only by ``exchange`` and ``canvas``.
"""
