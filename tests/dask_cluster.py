"""A real Dask cluster on 127.0.0.1 for tests and benchmarks: `dask scheduler` and `dask worker` processes started
from this environment, waited for, and stopped (killed if they will not stop)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

DASK = Path(sys.executable).with_name("dask")
ROOT = Path(__file__).resolve().parents[1]
START_SECONDS = 60.0


class LocalCluster:
    """with LocalCluster(workers=2) as cluster: cluster.address, cluster.kill_worker(0), cluster.kill_scheduler()."""

    def __init__(self, workers: int = 2) -> None:
        self.folder = Path(tempfile.mkdtemp(prefix="weathervane-dask-"))
        self.scheduler_file = self.folder / "scheduler.json"
        self.workers = workers
        self.processes: list[subprocess.Popen] = []
        self.address = ""

    def _start(self, *arguments: str, log: str) -> subprocess.Popen:
        with open(self.folder / log, "wb") as output:
            # the workers import this checkout's code, not the one the environment has installed (a worktree's)
            environment = {
                **os.environ,
                "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
            }
            process = subprocess.Popen(
                [str(DASK), *arguments],
                stdout=output,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                env=environment,
            )
        self.processes.append(process)
        return process

    def __enter__(self) -> LocalCluster:
        arguments = ["--host", "127.0.0.1", "--port", "0", "--scheduler-file", str(self.scheduler_file)]
        self.scheduler = self._start("scheduler", *arguments, "--no-dashboard", log="scheduler.log")
        deadline = time.monotonic() + START_SECONDS
        while not self.scheduler_file.exists():
            if time.monotonic() > deadline or self.scheduler.poll() is not None:
                self.__exit__()
                raise RuntimeError(f"dask scheduler did not start: {(self.folder / 'scheduler.log').read_text()}")
            time.sleep(0.1)
        self.address = json.loads(self.scheduler_file.read_text())["address"]
        self.worker_processes = [
            self._start(
                "worker",
                "--scheduler-file",
                str(self.scheduler_file),
                "--nthreads",
                "1",
                "--no-nanny",  # one process per worker, so that killing it loses it
                "--no-dashboard",
                "--name",
                f"worker-{index}",
                log=f"worker-{index}.log",
            )
            for index in range(self.workers)
        ]
        from distributed import Client

        try:
            with Client(self.address, timeout=START_SECONDS) as client:
                client.wait_for_workers(self.workers, timeout=START_SECONDS)
        except Exception:
            self.__exit__()  # no process outlives a cluster that did not start
            raise
        return self

    def kill_worker(self, index: int) -> None:
        os.kill(self.worker_processes[index].pid, signal.SIGKILL)

    def kill_scheduler(self) -> None:
        os.kill(self.scheduler.pid, signal.SIGKILL)

    def __exit__(self, *_exc: object) -> None:
        for process in self.processes:
            if process.poll() is None:
                process.terminate()
        for process in self.processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait(10)
