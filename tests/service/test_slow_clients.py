"""Slow clients against a live server, with raw sockets: headers and bodies on a deadline (408, then closed),
chunked bodies over the limit answered 413 like sized ones, and none of it in the way of a normal client."""

from __future__ import annotations

import json
import socket
import time
from collections.abc import Iterator

import pytest

from harness.live import running_server

# Live servers (make test-fast skips them); the deadlines are asserted in seconds: alone on the cores.
pytestmark = [pytest.mark.slow, pytest.mark.serial]

HEADER_S, BODY_S, LIMIT = 1.0, 1.5, 100_000


@pytest.fixture(scope="module")
def port(tmp_path_factory: pytest.TempPathFactory) -> Iterator[int]:
    database = tmp_path_factory.mktemp("slow") / "slow.db"
    with running_server(
        f"sqlite:///{database}",
        IWR_JOB_WORKERS="0",
        IWR_WARM_UP="0",
        IWR_COMPUTE_PROCESSES="1",
        IWR_HEADER_TIMEOUT_SECONDS=str(HEADER_S),
        IWR_BODY_TIMEOUT_SECONDS=str(BODY_S),
        IWR_MAX_BODY_BYTES=str(LIMIT),
    ) as url:
        yield int(url.rsplit(":", 1)[1])


EARLY_S = 0.05
"""The server's clock starts when it accepts the connection, a moment before the client's `started`: a cut at
the deadline may look up to this much early from here (seen: 0.99999 s for a 1 s deadline)."""


def _connect(port: int) -> socket.socket:
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return sock


def _read_all(sock: socket.socket) -> bytes:
    data = b""
    try:
        while chunk := sock.recv(65536):
            data += chunk
    except OSError:
        pass  # reset: the test's assertions on `data` say what was received before it
    return data


def _read_response(sock: socket.socket) -> bytes:
    """One answer on a kept-alive connection: its head, then as many bytes as its Content-Length says."""
    data = b""
    while b"\r\n\r\n" not in data:
        data += sock.recv(65536)
    head, body = data.split(b"\r\n\r\n", 1)
    length = next(
        int(line.split(b":")[1]) for line in head.lower().split(b"\r\n") if line.startswith(b"content-length")
    )
    while len(body) < length:
        body += sock.recv(65536)
    return head + b"\r\n\r\n" + body


def _trickle(sock: socket.socket, data: bytes, every_s: float, for_s: float) -> bool:
    """Send `data` a byte at a time; False as soon as the server has closed the connection."""
    stop = time.monotonic() + for_s
    for byte in data:
        if time.monotonic() > stop:
            break
        try:
            sock.sendall(bytes([byte]))
        except OSError:
            return False
        time.sleep(every_s)
    return True


def _status(data: bytes) -> int:
    return int(data.split(b" ", 2)[1]) if data.startswith(b"HTTP/1.1 ") else 0


def _body(data: bytes) -> dict[str, object]:
    parsed: dict[str, object] = json.loads(data.split(b"\r\n\r\n", 1)[1])
    return parsed


def test_headers_sent_a_byte_at_a_time_are_cut_at_the_deadline(port: int) -> None:
    request = b"POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nX-Padding: " + b"a" * 200
    with _connect(port) as sock:
        started = time.perf_counter()
        _trickle(sock, request, every_s=0.05, for_s=4 * HEADER_S)  # uvicorn alone would wait for ever
        sock.settimeout(5)
        data = _read_all(sock)
        elapsed = time.perf_counter() - started
    assert _status(data) == 408 and "headers" in str(_body(data)["detail"])
    assert HEADER_S - EARLY_S <= elapsed < HEADER_S + 3.5  # cut at the deadline, not at the end of the trickle + slack
    assert b"connection: close" in data.lower()


def test_a_connection_that_sends_nothing_is_closed_at_the_deadline(port: int) -> None:
    with _connect(port) as sock:
        started = time.perf_counter()
        data = _read_all(sock)
        elapsed = time.perf_counter() - started
    assert _status(data) == 408 and HEADER_S - EARLY_S <= elapsed < HEADER_S + 2.5  # + slack for a loaded machine


def test_a_body_sent_a_byte_at_a_time_is_cut_at_its_deadline(port: int) -> None:
    body = b'{"name": "' + b"s" * 500 + b'"}'
    head = (
        f"POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n"
    )
    with _connect(port) as sock:
        sock.sendall(head.encode())  # the headers in time: the body's own deadline applies
        started = time.perf_counter()
        _trickle(sock, body, every_s=0.05, for_s=BODY_S + 1.0)
        sock.settimeout(5)
        data = _read_all(sock)
        elapsed = time.perf_counter() - started
    assert _status(data) == 408 and "body" in str(_body(data)["detail"])  # one answer, then closed
    assert BODY_S - EARLY_S <= elapsed < BODY_S + 2.0 and b"connection: close" in data.lower()


def test_a_chunked_body_over_the_limit_is_a_413_like_a_declared_one(port: int) -> None:
    # Connection: close, as the sized request below: the answer is read to the end of the connection, which
    # otherwise stays open for uvicorn's keep-alive (5 s of waiting here).
    head = (
        b"POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nTransfer-Encoding: chunked\r\n"
        b"Connection: close\r\n\r\n"
    )
    chunk = b"x" * 10_000
    with _connect(port) as sock:
        sock.sendall(head)
        for _ in range(3 * LIMIT // len(chunk)):  # three times the limit, no Content-Length to refuse up front
            sock.sendall(f"{len(chunk):x}\r\n".encode() + chunk + b"\r\n")
        sock.sendall(b"0\r\n\r\n")
        chunked = _read_all(sock)
    declared = (
        f"POST /v1/robots HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {3 * LIMIT}\r\n"
    )
    with _connect(port) as sock:
        sock.sendall(declared.encode() + b"Connection: close\r\n\r\n")
        sized = _read_all(sock)
    assert _status(chunked) == _status(sized) == 413  # the whole answer read: no reset mid-upload
    assert _body(chunked)["type"] == _body(sized)["type"] and _body(chunked)["limit"] == LIMIT


def test_a_normal_client_is_not_hurried(port: int) -> None:
    # Two requests on one kept-alive connection, the second after more than the header deadline of idling
    # (the idle time is uvicorn's keep-alive, 5 s); each sends its headers at once.
    get = b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n"
    with _connect(port) as sock:
        sock.sendall(get)
        answers = [_read_response(sock)]
        time.sleep(HEADER_S + 0.5)
        sock.sendall(get)
        answers.append(_read_response(sock))
    assert [_status(a) for a in answers] == [200, 200]


def test_the_next_request_on_a_kept_alive_connection_has_the_deadline_too(port: int) -> None:
    with _connect(port) as sock:
        sock.sendall(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        assert _status(_read_response(sock)) == 200
        started = time.perf_counter()
        _trickle(sock, b"GET /healthz HTTP/1.1\r\nHost: x\r\nX-Slow: " + b"b" * 200, every_s=0.05, for_s=3.0)
        sock.settimeout(5)
        data = _read_all(sock)
    assert _status(data) == 408 and time.perf_counter() - started < HEADER_S + 3.5
