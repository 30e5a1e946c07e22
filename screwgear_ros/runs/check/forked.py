"""A computation of the check in a forked process while this one goes on.

The check's costly parts are independent once the recording is read and replayed at
dt: the RK4 replay at dt/2 and the reference at its two tolerances. :class:`Forked`
runs one of them in a child forked from this process (which inherits the recording,
the replay and the kernels loaded so far, so nothing is sent to it) and hands the
result back through a pipe. Without ``fork``, with one core, or with ``parallel`` off,
it runs here when its result is asked for; a child that dies, or fails in a way that
is not one of the package's errors, is redone here, so the result and the error raised
are the same either way: the same code on the same data.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Generic, TypeVar

from ...errors import ScrewgearError
from ...sim.machine import cores

T = TypeVar('T')


class Forked(Generic[T]):
    """``work(forked)`` in a forked child started now, or here when :meth:`result` is
    asked for; ``forked`` tells the work where it runs (a child cannot report
    progress)."""

    def __init__(self, work: Callable[[bool], T], parallel: bool, name: str) -> None:
        self.work = work
        self.proc: BaseProcess | None = None
        self.conn: Connection | None = None
        self.forked = False
        if parallel and cores() > 1 and 'fork' in mp.get_all_start_methods():
            ctx = mp.get_context('fork')
            self.conn, child = ctx.Pipe(duplex=False)
            self.proc = ctx.Process(target=self._run, args=(work, child), daemon=True,
                                    name=name)
            self.proc.start()
            child.close()
            self.forked = True          # the work runs in a child

    @staticmethod
    def _run(work: Callable[[bool], T], conn: Connection) -> None:   # in the child
        try:
            answer: tuple[str, object] = ('ok', work(True))
        except ScrewgearError as exc:       # the package's verdict on the data: raise it there
            answer = ('error', exc)
        except BaseException as exc:  # noqa: BLE001 - redone in the parent, which raises it
            answer = ('redo', f'{type(exc).__name__}: {exc}')
        try:
            conn.send(answer)
        except Exception:  # noqa: BLE001, S110 - e.g. an error that does not pickle:
            pass           # the parent sees the pipe close and redoes the work
        finally:
            conn.close()

    def result(self) -> T:
        """The work's result (raising what the work raised)."""
        answer = None
        if self.proc is not None and self.conn is not None:
            try:
                answer = self.conn.recv()
            except Exception:  # noqa: BLE001 - the child died, or its error does not unpickle
                answer = None                  # redo it here
            self.close()
        if answer is not None and answer[0] == 'ok':
            return answer[1]
        if answer is not None and answer[0] == 'error':
            raise answer[1]
        return self.work(False)

    def close(self) -> None:
        """End the child (if it still runs) and free the pipe."""
        if self.proc is not None and self.conn is not None:
            if self.proc.is_alive():
                self.proc.terminate()
            self.proc.join()
            self.conn.close()
            self.proc = None


__all__ = ['Forked', 'cores']
