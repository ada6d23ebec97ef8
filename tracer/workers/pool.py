"""Tasks -> results on worker processes that the parent watches: a worker that dies has its tasks run again.

multiprocessing.Pool waits forever for the result of a worker killed by a signal (the OOM killer, kill -9), and its
workers print KeyboardInterrupt tracebacks on Ctrl-C. This pool is small and explicit instead: each worker has a
pipe of its own, the parent waits on every pipe and every worker's exit sentinel at once, so a death is seen as it
happens; its tasks go back to the queue and a fresh worker takes its place. A task is a pure function of its
arguments, so a re-run gives the same bytes. Workers ignore Ctrl-C (the parent decides), and leave quietly when the
parent is gone (their pipe closes).

A task may carry file descriptors (the shared image of a frame, a large scene's arrays: memfds): they go to the
worker over the pipe (SCM_RIGHTS) right after the task, so no file name is ever made that a killed parent could
leave behind.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import queue
import signal
import sys
import threading
import traceback
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from multiprocessing import connection, reduction
from typing import Any

# Tasks sent ahead to each worker, so that it never waits for the parent between two tasks (the parent may be busy
# elsewhere for a while, e.g. handing a finished frame to its writer).
TASKS_AHEAD = 2
# Times one task may be under a worker that dies before the pool gives up: a task that kills every worker it meets
# (one that needs more memory than there is) must not restart workers forever.
MAX_ATTEMPTS = 3
TERMINATE_SECONDS = 2.0


class WorkerLostError(RuntimeError):
    """A task's workers died MAX_ATTEMPTS times (killed by a signal, out of memory, ...)."""


class PoolClosedError(RuntimeError):
    """The pool was closed (from another thread) while tasks were waiting on it: no worker is started again."""


class TaskFailedError(RuntimeError):
    """A task raised in a worker; details holds the worker's traceback."""

    def __init__(self, message: str, details: str) -> None:
        super().__init__(message)
        self.details = details


@dataclass(eq=False)
class Task:
    function: Callable[..., Any]
    args: tuple
    descriptors: tuple[int, ...] = ()  # file descriptors the worker receives as the function's last arguments
    attempts: int = 0
    done: bool = False
    cancelled: bool = False
    result: Any = None
    error: BaseException | None = None

    def value(self) -> Any:
        if self.error is not None:
            raise self.error
        return self.result


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: connection.Connection
    tasks: deque[Task] = field(default_factory=deque)  # sent, in the order they will come back


def _worker_main(conn: connection.Connection, inherited: list[int], niceness: int = 0) -> None:
    if niceness and hasattr(os, "nice"):
        with contextlib.suppress(OSError):  # a lower priority is a courtesy: without it the work is the same
            os.nice(niceness)
    for descriptor in inherited:  # a forked worker's copies of the parent's other pipes and images: let them go,
        with contextlib.suppress(OSError):  # or a pipe would stay open after the parent dies
            os.close(descriptor)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole process group; the parent handles it
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    # A thread takes tasks off the pipe as they come, so that the parent's send of a task never waits for this
    # worker's send of a result (both would block on full pipes with large messages: pixel lists and colours)
    tasks: queue.SimpleQueue = queue.SimpleQueue()
    threading.Thread(target=_receive_tasks, args=(conn, tasks), daemon=True, name="weathervane-tasks").start()
    while True:
        message = tasks.get()
        if message is None:  # stopped, or the parent is gone
            return
        function, args, descriptors = message
        try:
            result = (True, function(*args, *descriptors))
        except Exception as error:
            result = (False, (f"{type(error).__name__}: {error}", traceback.format_exc()))
        finally:
            for descriptor in descriptors:
                os.close(descriptor)
        try:
            conn.send(result)
        except (OSError, ValueError):  # the parent is gone
            return


@contextlib.contextmanager
def _main_script_hidden(hide: bool) -> Iterator[None]:
    """A started (not forked) child runs the parent's main script again before it takes a task; the workers need only
    the tracer's modules, and a script that Blender runs would import bpy there, which a plain Python has not."""
    main = sys.modules.get("__main__")
    if not hide or main is None:
        yield
        return
    saved = {name: main.__dict__[name] for name in ("__file__", "__spec__") if name in main.__dict__}
    main.__dict__.pop("__file__", None)
    main.__spec__ = None  # multiprocessing reads it: a module name would be imported again instead
    try:
        yield
    finally:
        main.__dict__.pop("__spec__", None)
        main.__dict__.update(saved)


def _receive_tasks(conn: connection.Connection, tasks: queue.SimpleQueue) -> None:
    """The worker's reader: (function, args, descriptors) for each task, then None."""
    try:
        while True:
            message = conn.recv()
            if message is None:
                break
            function, args, count = message
            tasks.put((function, args, tuple(reduction.recv_handle(conn) for _ in range(count))))
    except (EOFError, OSError):  # the parent is gone
        pass
    tasks.put(None)


HEARTBEAT_SECONDS = 0.1


class WorkerPool:
    """workers processes that run Tasks; results are collected by the parent calling wait()."""

    def __init__(
        self,
        workers: int,
        start_method: str = "fork",
        private: Callable[[], list[int]] | None = None,
        niceness: int = 0,
    ) -> None:
        """private: the parent's other descriptors that a forked worker must not keep (files the parent reuses).
        niceness: added to each worker's (Unix nice): a pool whose images a program draws as they come leaves the
        CPU to that drawing first."""
        self.size = workers
        self._niceness = niceness
        self._private = private
        self._context = multiprocessing.get_context(start_method)
        self._workers: list[_Worker] = []
        self._queue: deque[Task] = deque()
        self.restarts = 0  # workers replaced after a death, over the pool's life
        self._closed = False  # set by close(), from any thread: no worker is started or replaced after it
        # called every HEARTBEAT_SECONDS while the parent waits and no result comes (workers preparing a large
        # scene take seconds before their first band): it may raise to stop waiting, as a user's cancel does
        self.heartbeat: Callable[[], None] | None = None
        for _ in range(workers):
            self._start_worker()

    # ---- tasks -------------------------------------------------------------------------------------------------

    def submit(self, function: Callable[..., Any], args: tuple, descriptors: tuple[int, ...] = ()) -> Task:
        """Queue function(*args, *descriptors), each descriptor received in the worker as one of its own."""
        if self._closed:
            raise PoolClosedError("the worker pool is closed")
        task = Task(function, args, descriptors)
        self._queue.append(task)
        self._dispatch()
        return task

    def cancel(self, tasks: Iterable[Task]) -> None:
        """Forget tasks: queued ones are dropped, running ones finish and their results are thrown away."""
        for task in tasks:
            task.cancelled = True
        self._queue = deque(task for task in self._queue if not task.cancelled)

    def as_completed(self, tasks: list[Task]) -> Iterator[Task]:
        """The tasks, each as it finishes (raising its error if it failed)."""
        waiting = [task for task in tasks if not task.done]
        for task in tasks:
            if task.done:
                task.value()
                yield task
        while waiting:
            self._wait()
            for task in [task for task in waiting if task.done]:
                waiting.remove(task)
                task.value()
                yield task

    # ---- workers -----------------------------------------------------------------------------------------------

    def _start_worker(self) -> None:
        if self._closed:
            return
        parent_end, child_end = multiprocessing.Pipe(duplex=True)
        inherited = []
        if self._context.get_start_method() == "fork":
            inherited = [w.conn.fileno() for w in self._workers] + [parent_end.fileno()]
            inherited += [d for t in self._queue for d in t.descriptors]
            inherited += [d for w in self._workers for t in w.tasks for d in t.descriptors]
            inherited += self._private() if self._private is not None else []
        process = self._context.Process(
            target=_worker_main,
            args=(child_end, sorted(set(inherited)), self._niceness),
            daemon=True,
            name="weathervane-worker",
        )
        # Ctrl-C in a terminal goes to the whole process group: held back until the worker has set it to be ignored
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            with _main_script_hidden(self._context.get_start_method() != "fork"):
                process.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        child_end.close()
        self._workers.append(_Worker(process, parent_end))

    def _dispatch(self) -> None:
        """Send queued tasks to the workers, each next task to the worker with the fewest in hand (up to
        TASKS_AHEAD), so that tasks spread over the workers: filling one worker's TASKS_AHEAD before the next
        gave both bands of a 2-band frame to the first of 2 workers, which traced them one after the other while
        the second idled (the default frame 1.7x slower)."""
        dead: set[int] = set()
        while self._queue:
            ready = [w for w in self._workers if id(w) not in dead and len(w.tasks) < TASKS_AHEAD]
            if not ready:
                return
            worker = min(ready, key=lambda w: len(w.tasks))  # the first of the least busy
            task = self._queue.popleft()
            try:
                worker.conn.send((task.function, task.args, len(task.descriptors)))
                for descriptor in task.descriptors:
                    reduction.send_handle(worker.conn, descriptor, worker.process.pid)
            except OSError:  # the worker died: its sentinel says so in the next wait
                self._queue.appendleft(task)
                dead.add(id(worker))
                continue
            worker.tasks.append(task)

    def _wait(self) -> None:
        """Block until a worker sends a result or dies; handle it and refill the workers. Raises PoolClosedError once
        the pool is closed (another thread closed it while this one waited: the workers it ended are not replaced)."""
        workers = list(self._workers)
        if self._closed or not workers:
            raise PoolClosedError("the worker pool is closed")
        timeout = HEARTBEAT_SECONDS if self.heartbeat is not None else None
        ready = connection.wait([w.conn for w in workers] + [w.process.sentinel for w in workers], timeout)
        if self._closed:
            raise PoolClosedError("the worker pool is closed")
        if not ready and self.heartbeat is not None:
            self.heartbeat()
        for worker in list(self._workers):
            # a dead worker's pipe reads as ready too (end of file), after any results it sent before dying
            if (worker.conn in ready or worker.process.sentinel in ready) and not self._receive(worker):
                self._replace(worker)
        self._dispatch()

    def _receive(self, worker: _Worker) -> bool:
        """Take every result the worker has sent; False when its pipe is closed (the worker is gone)."""
        try:
            while worker.conn.poll():
                ok, payload = worker.conn.recv()
                task = worker.tasks.popleft()
                task.done = True
                if ok:
                    task.result = payload
                else:
                    summary, details = payload
                    task.error = TaskFailedError(f"a worker failed: {summary}", details)
        except (EOFError, OSError):
            return False
        return worker.process.is_alive() or worker.process.exitcode is None

    def _replace(self, worker: _Worker) -> None:
        """A worker exited with tasks in hand (or none): put them back, first in the queue, and start another."""
        worker.process.join()
        code = worker.process.exitcode
        worker.conn.close()
        self._workers.remove(worker)
        for task in reversed(worker.tasks):
            task.attempts += 1
            if task.attempts >= MAX_ATTEMPTS:
                how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
                task.done = True
                task.error = WorkerLostError(
                    f"a worker process died {task.attempts} times on the same part of the image ({how}); "
                    "if the system ran out of memory, try fewer workers, --dtype float32 or a smaller image"
                )
            elif not task.cancelled:
                self._queue.appendleft(task)
        if not self._closed:
            self.restarts += 1
            self._start_worker()

    def close(self) -> None:
        """Stop every worker now (running tasks are abandoned; a thread waiting on them gets PoolClosedError)."""
        self._closed = True
        workers, self._workers = self._workers, []
        self._queue.clear()
        for worker in workers:
            with contextlib.suppress(OSError):
                worker.conn.send(None)
            if worker.process.is_alive():
                worker.process.terminate()  # SIGTERM: a worker has no handler, so it ends without a word
        for worker in workers:
            worker.process.join(TERMINATE_SECONDS)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            worker.conn.close()

    def pids(self) -> list[int]:
        return [worker.process.pid for worker in self._workers]
