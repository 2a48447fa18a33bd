"""A Python model evaluated on a Dask cluster (``[compute] scheduler``, ``--scheduler``).

The same evaluations as :class:`~edmf_rs.simulators.pool.FunctionPool`, on
the workers of a ``distributed`` scheduler instead of local processes: each
batch is cut into one contiguous piece per worker thread, each piece is one
task that imports ``module:function`` on its worker (as `edmf_rs.dask`
asks: the model must be importable there, e.g. the project folder on a
shared file system or the module installed) and sends back what the model
returned, names and all. Pieces come back in instance order and are matched
to the sensors by the caller, so results, prediction store and failure
accounting are those of a local run. A task whose worker dies is
rescheduled by Dask like any other.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .failures import SimulationError
from .pool import _call

#: Seconds to wait for the scheduler before refusing its address.
CONNECT_TIMEOUT = 5.0


class SchedulerUnreachable(OSError):
    """The Dask scheduler cannot be reached (or ``distributed`` is not installed).

    Examples
    --------
    >>> issubclass(SchedulerUnreachable, OSError)
    True
    """


def check_address(address) -> None:
    """Refuses an address no Dask scheduler can have (empty, no port, bad IPv6 brackets, unknown
    scheme, an in-process address with no scheduler in this process) before any connection is tried.

    Raises
    ------
    SchedulerUnreachable
        Naming the address and what is wrong with it.

    Examples
    --------
    >>> check_address("tcp://10.0.0.5:8786")
    >>> check_address("not-an-address")
    Traceback (most recent call last):
    ...
    edmf_rs.simulators.cluster.SchedulerUnreachable: not a Dask scheduler address: 'not-an-address' (missing port number in address 'not-an-address'); expected e.g. tcp://host:8786
    """
    example = "expected e.g. tcp://host:8786"
    if not isinstance(address, str) or not address.strip():
        raise SchedulerUnreachable(f"not a Dask scheduler address: {address!r} (empty); {example}")
    try:
        from distributed.comm.addressing import get_address_host_port, parse_address
    except ImportError:
        return  # refused with the install hint by ClusterPool
    try:
        scheme, location = parse_address(address)
        if scheme == "inproc":  # a scheduler in this very process (LocalCluster(processes=False))
            from distributed.comm.inproc import global_manager

            if global_manager.get_listener_for(location) is None:
                raise ValueError("no scheduler of this process listens there")
        else:
            get_address_host_port(address)
    except (ValueError, TypeError) as exc:
        raise SchedulerUnreachable(f"not a Dask scheduler address: {address!r} ({exc}); {example}") from None


class ClusterPool:
    """``function(theta, **options)`` evaluated on the workers of a Dask scheduler.

    Parameters
    ----------
    address : str
        The scheduler, e.g. ``"tcp://10.0.0.5:8786"``.
    ref : str
        ``module:function``, imported on each worker with ``path`` on sys.path.
    path : str or pathlib.Path
        Folder of the model's module.
    options : dict
        Keyword arguments of every call.
    timeout : float, default CONNECT_TIMEOUT
        Seconds to wait for the scheduler.

    Raises
    ------
    SchedulerUnreachable
        When the scheduler does not answer within ``timeout`` seconds, or
        ``distributed`` is not installed.

    Examples
    --------
    >>> ClusterPool("tcp://127.0.0.1:1", "numpy:cumsum", ".", {}, timeout=0.5)
    Traceback (most recent call last):
    ...
    edmf_rs.simulators.cluster.SchedulerUnreachable: cannot reach the Dask scheduler at tcp://127.0.0.1:1 ...
    """

    def __init__(self, address: str, ref: str, path: str | Path, options: dict, *,
                 timeout: float = CONNECT_TIMEOUT):
        self.address, self.ref, self.options = address, ref, dict(options)
        self.path = str(Path(path).resolve())
        try:
            from distributed import Client
        except ImportError:
            raise SchedulerUnreachable(
                f"a Dask scheduler ({address}) needs the distributed package: install edmf_rs[dask] "
                "(pip install -e '.[dask]' in the checkout)") from None
        check_address(address)  # before a Client: a half-made one blocks ~10 s and warns when collected
        try:
            self.client = Client(address, timeout=timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise SchedulerUnreachable(f"cannot reach the Dask scheduler at {address} within {timeout:g} s "
                                       f"({type(exc).__name__}: {exc})") from None

    @property
    def threads(self) -> int:
        """Worker threads of the cluster now (at least 1)."""
        return max(sum(self.client.nthreads().values()), 1)

    def pieces(self, theta: np.ndarray, first: int) -> list[tuple[int, object]]:
        """(rows, what the model returned) for each contiguous piece of the batch, in order."""
        pieces = [p for p in np.array_split(theta, self.threads) if len(p)]
        futures = [self.client.submit(_call, self.ref, self.path, self.options, np.ascontiguousarray(p), pure=False)
                   for p in pieces]
        try:
            return [(len(p), out) for p, out in zip(pieces, self.client.gather(futures))]
        except Exception as exc:
            if getattr(exc, "__module__", "").startswith("distributed"):  # KilledWorker, lost scheduler, ...
                raise SimulationError(
                    f"the Dask cluster at {self.address} failed evaluating model.function = '{self.ref}' on "
                    f"instances {first}..{first + len(theta) - 1}: {type(exc).__name__}: {exc}; the instances "
                    "before them are kept in the prediction store") from None
            raise  # the model's own exception, re-raised here by Dask
        finally:
            for f in futures:
                f.release()

    def close(self) -> None:
        self.client.close()
