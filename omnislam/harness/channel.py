"""Progress of runs in worker processes, sent back to the process that shows it.

The grid runner hands every cell a ``StepReporter`` (picklable: an address and a key) that
``execute_run`` calls as it goes (``on_step(stage, done, total)``); the reporter sends at most one
message every ``SEND_INTERVAL_S`` (plus every change of stage) over a
``multiprocessing.connection`` socket to the ``ProgressChannel`` of the runner's process, whose
reader threads queue them; the runner drains the queue while it waits for cells. The socket is
local (a Unix socket, authenticated by a random key), so workers of a local process pool or of
a Dask cluster on this machine report frames as they go; a worker that cannot reach it (a
remote Dask worker) stays silent, and its cell shows progress only when it finishes. Progress
never fails a run: every error of the channel is swallowed on both sides.
"""

from __future__ import annotations

import os
import queue
import threading
import time
from dataclasses import dataclass
from multiprocessing.connection import Client, Connection, Listener
from types import TracebackType

#: seconds between two messages of one reporter (a change of stage is sent at once)
SEND_INTERVAL_S = 0.5


@dataclass(frozen=True, slots=True)
class StepMessage:
    """What a run is doing: ``stage`` ("loading", "running", ...), ``done`` of ``total``
    frames (0 of 0 while nothing is counted), for the cell ``key``."""

    key: str
    stage: str
    done: int
    total: int


#: one open connection per (process, address): a worker runs many cells one after another
_CONNECTIONS: dict[tuple[int, str], Connection | None] = {}


class StepReporter:
    """``on_step`` callback of a run in a worker: sends StepMessages to a ProgressChannel.

    Args:
        address: the channel's listener address.
        authkey: the channel's key.
        key: the cell this reporter speaks for.
    """

    def __init__(self, address: str, authkey: bytes, key: str) -> None:
        self.address = address
        self.authkey = authkey
        self.key = key
        self._last_sent = -1e18
        self._stage = ""

    def __getstate__(self) -> dict[str, object]:
        return {"address": self.address, "authkey": self.authkey, "key": self.key}

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__init__(state["address"], state["authkey"], state["key"])  # type: ignore[misc, arg-type]

    def __call__(self, stage: str, done: int, total: int) -> None:
        now = time.monotonic()
        last = stage != self._stage or (total > 0 and done >= total)
        if not last and now - self._last_sent < SEND_INTERVAL_S:
            return
        self._stage = stage
        self._last_sent = now
        connection = self._connection()
        if connection is None:
            return
        try:
            connection.send((self.key, stage, int(done), int(total)))
        except (OSError, EOFError, ValueError):
            _CONNECTIONS[(os.getpid(), self.address)] = None  # the channel is gone: stay silent

    def _connection(self) -> Connection | None:
        slot = (os.getpid(), self.address)
        if slot not in _CONNECTIONS:
            try:
                _CONNECTIONS[slot] = Client(self.address, authkey=self.authkey)
            except Exception:  # unreachable (remote worker), refused, wrong key: no progress
                _CONNECTIONS[slot] = None
        return _CONNECTIONS[slot]


class ProgressChannel:
    """Receives StepMessages from workers on this machine (a context manager).

    ``reporter(key)`` makes the callback to hand to a worker; ``drain()`` returns what arrived
    since the last call, in order of arrival.
    """

    def __init__(self) -> None:
        self._authkey = os.urandom(32)
        self._listener = Listener(authkey=self._authkey)
        self._queue: queue.SimpleQueue[StepMessage] = queue.SimpleQueue()
        self._closed = threading.Event()
        self._accepter = threading.Thread(target=self._accept, daemon=True, name="progress")
        self._accepter.start()

    @property
    def address(self) -> str:
        return str(self._listener.address)

    def reporter(self, key: str) -> StepReporter:
        """The callback a worker calls for cell ``key``."""
        return StepReporter(self.address, self._authkey, key)

    def drain(self) -> list[StepMessage]:
        """Every message received since the last call."""
        out = []
        while True:
            try:
                out.append(self._queue.get_nowait())
            except queue.Empty:
                return out

    def close(self) -> None:
        """Stop listening (workers that still send are ignored)."""
        if self._closed.is_set():
            return
        self._closed.set()
        try:  # wake the accepting thread so that it sees the flag
            Client(self.address, authkey=self._authkey).close()
        except Exception:
            pass
        try:
            self._listener.close()
        except OSError:
            pass

    def __enter__(self) -> ProgressChannel:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()

    def _accept(self) -> None:
        while not self._closed.is_set():
            try:
                connection = self._listener.accept()
            except Exception:  # closed, or a client with the wrong key
                if self._closed.is_set():
                    return
                continue
            if self._closed.is_set():
                connection.close()
                return
            threading.Thread(
                target=self._read, args=(connection,), daemon=True, name="progress-reader"
            ).start()

    def _read(self, connection: Connection) -> None:
        with connection:
            while not self._closed.is_set():
                try:
                    key, stage, done, total = connection.recv()
                except Exception:  # the worker ended (EOF) or sent garbage
                    return
                self._queue.put(StepMessage(str(key), str(stage), int(done), int(total)))
