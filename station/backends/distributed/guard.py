"""One rank's failure must end the whole MPI job, never leave it hanging.

An exception that ends one rank's program normally would reach ``MPI_Finalize``,
which waits for the other ranks, while they wait in a collective for this one:
the job would hang. :func:`abort_job_on_error` turns any exception but bad input
into ``MPI_Abort`` with a one-line message naming the rank. Bad input
(:class:`~station.errors.BadInput`) is raised on every rank alike (the ranks check
the same arguments and records before any communication), so it ends the program
normally, exit code 2, after rank 0 has written what it must.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

from station.errors import BadInput


@contextmanager
def abort_job_on_error() -> Iterator[None]:
    try:
        yield
    except (BadInput, SystemExit):
        raise
    except BaseException as exc:
        from mpi4py import MPI

        rank = MPI.COMM_WORLD.Get_rank()
        sys.stderr.write(f"station: rank {rank} failed ({exc.__class__.__name__}: {exc}); "
                         "aborting the MPI job\n")
        sys.stderr.flush()
        # mpiexec forwards a rank's stderr asynchronously and stops forwarding once the
        # abort kills the job: give it a moment, or the one line saying why can be lost
        time.sleep(0.5)
        MPI.COMM_WORLD.Abort(1)
        raise
