"""``pcl-rg batch --scheduler`` at an address where no Dask scheduler answers: a clear
one-line error within Dask's connect timeout, not a hang or a bogus MemoryError."""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
import warnings

import pytest
from conftest import run_pcl_rg

from pcl_rg.datasets import synthetic_survey

# Dask's connect timeout for the commands below (pcl-rg waits twice that and 5 s).
CONNECT_TIMEOUT = {"DASK_DISTRIBUTED__COMM__TIMEOUTS__CONNECT": "1s"}


@contextlib.contextmanager
def tcp_server(reply: bytes | None):
    """A local TCP server that answers every connection with `reply` and closes it, or
    (None) accepts and then says nothing; yields its address."""
    listener = socket.create_server(("127.0.0.1", 0))
    accepted: list[socket.socket] = []

    def serve() -> None:
        with contextlib.suppress(OSError):  # the listener closed
            while True:
                connection, _ = listener.accept()
                accepted.append(connection)
                if reply is not None:
                    with contextlib.suppress(OSError):
                        connection.recv(4096)
                        connection.sendall(reply)
                    connection.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    finally:
        listener.close()
        for connection in accepted:
            connection.close()


@pytest.mark.parametrize(
    ("reply", "message"),
    [
        (None, "no Dask scheduler answered at"),  # a silent service
        (b"HTTP/1.1 400 Bad Request\r\ncontent-length: 0\r\n\r\n", "is not a Dask scheduler"),
    ],
)
def test_an_address_without_a_scheduler_is_a_clear_error(reply, message, tmp_path):
    source = synthetic_survey(tmp_path / "in", tiles=(1, 1), tile_size=20.0, seed=1)
    with tcp_server(reply) as address:
        result = run_pcl_rg(
            "batch",
            "ground",
            *source.paths,
            "--out",
            tmp_path / "out",
            "--scheduler",
            address,
            timeout=60,
            env={**os.environ, **CONNECT_TIMEOUT},
        )
    assert result.returncode == 2, result.stderr
    assert message in result.stderr and "8786" in result.stderr, result.stderr
    # One line, but for make sanitize's note of the absurd allocation ("==pid==WARNING").
    lines = [line for line in result.stderr.splitlines() if not line.startswith("==")]
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert not os.path.exists(tmp_path / "out" / "tile_0_0.laz")


def test_a_client_that_connects_after_the_deadline_is_closed(monkeypatch):
    """The connecting thread outlives the caller's deadline: a Client it makes then is
    closed at once, not left open and unowned."""
    import dask
    import distributed

    from pcl_rg.batch import _cluster

    made: list[object] = []
    closed = threading.Event()
    release = threading.Event()

    class SlowClient:
        def __init__(self, address: str) -> None:
            release.wait(30)
            made.append(self)

        def close(self) -> None:
            closed.set()

    monkeypatch.setattr(distributed, "Client", SlowClient)
    monkeypatch.setattr(_cluster, "CONNECT_SLACK_SECONDS", 0.2)
    with dask.config.set({"distributed.comm.timeouts.connect": "0s"}):
        with pytest.raises(ConnectionError, match="no Dask scheduler answered.*8786"):
            _cluster._connect("tcp://127.0.0.1:1")
    release.set()
    assert closed.wait(30) and len(made) == 1


def test_a_scheduler_without_workers_is_said_and_waited_on(tmp_path, monkeypatch):
    # The tasks waited for a worker in silence. Now a warning says so, and the run goes
    # on once a worker comes (an adaptive cluster starts them only for tasks). In a
    # thread with a deadline, so that a regression fails instead of hanging the suite.
    from distributed import LocalCluster

    from pcl_rg import batch
    from pcl_rg.batch import _cluster

    source = synthetic_survey(tmp_path / "in", tiles=(1, 1), tile_size=20.0, seed=1)
    monkeypatch.setattr(_cluster, "WORKER_WAIT_SECONDS", 0.5)
    reports: list[object] = []
    with (
        LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as cluster,
        warnings.catch_warnings(record=True) as caught,
    ):
        warnings.simplefilter("always")
        address = cluster.scheduler_address
        attempt = threading.Thread(
            target=lambda: reports.append(
                batch.ground(source.paths, tmp_path / "out", scheduler=address)
            ),
            daemon=True,
        )
        attempt.start()
        said = [f"the Dask scheduler at {address} has had no worker for 0.5 s"]
        for _ in range(600):
            if any(said[0] in str(w.message) for w in caught):
                break
            time.sleep(0.05)
        assert any(said[0] in str(w.message) for w in caught)
        assert attempt.is_alive()  # waiting, not failed
        cluster.scale(1)
        attempt.join(60)
        assert not attempt.is_alive(), "the run is still waiting for a worker"
    assert [t.status for t in reports[0].tiles] == ["done"]
