"""A small open-loop HTTP/1.1 load generator on raw asyncio streams.

Python HTTP clients spend a millisecond or more of CPU per request; on a 2-core machine that shares the
cores with the server, that cost shows up as server latency. This one writes pre-built requests on
keep-alive connections and reads responses by Content-Length: tens of microseconds per request.
"""

from __future__ import annotations

import asyncio
import json
import socket
import time
from urllib.parse import urlsplit


def request_bytes(host: str, path: str, body: object) -> bytes:
    """A JSON POST on a kept-alive connection."""
    return raw_request(host, "POST", path, json.dumps(body).encode(), keep_alive=True)


async def _read_response(reader: asyncio.StreamReader) -> int:
    head = await reader.readuntil(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    status = int(lines[0].split()[1])
    length = next(int(line.split(":", 1)[1]) for line in lines if line.lower().startswith("content-length:"))
    await reader.readexactly(length)
    return status


async def open_loop(
    base_url: str, requests: list[bytes], clients: int, period_s: float, duration_s: float
) -> tuple[list[float], int]:
    """Each client sends one request every `period_s` on its own connection; returns (latencies s, errors)."""
    parts = urlsplit(base_url)
    latencies: list[float] = []
    errors = 0
    stop = time.perf_counter() + duration_s

    async def client(k: int) -> None:
        nonlocal errors
        reader, writer = await asyncio.open_connection(parts.hostname, parts.port)
        await asyncio.sleep(period_s * k / clients)
        i = 0
        try:
            while time.perf_counter() < stop:
                due = time.perf_counter() + period_s
                started = time.perf_counter()
                writer.write(requests[(k + i) % len(requests)])
                await writer.drain()
                status = await _read_response(reader)
                latencies.append(time.perf_counter() - started)
                errors += status != 200
                i += 1
                await asyncio.sleep(max(0.0, due - time.perf_counter()))
        finally:
            writer.close()
            await writer.wait_closed()

    await asyncio.gather(*(client(k) for k in range(clients)))
    return latencies, errors


# One request per connection (`Connection: close`), for what must be timed from a process of its own (a probe,
# the refusals of benchmarks/bench_hardening.py): this module imports the standard library only, so such a process
# starts in ~0.1 s of CPU, where importing the benchmark (numpy, CasADi, the models) took ~2 s, six times over, on
# the cores the server under load shares.


def raw_request(
    host: str,
    method: str,
    path: str,
    body: bytes = b"",
    headers: dict[str, str] | None = None,
    *,
    keep_alive: bool = False,
) -> bytes:
    """A request's bytes as sent on the wire: one request per connection unless `keep_alive`."""
    lines = [f"{method} {path} HTTP/1.1", f"Host: {host}", f"Connection: {'keep-alive' if keep_alive else 'close'}"]
    extra = {"Content-Type": "application/json", "Content-Length": str(len(body))} if method == "POST" else {}
    extra.update(headers or {})
    lines += [f"{k}: {v}" for k, v in extra.items()]
    return ("\r\n".join(lines) + "\r\n\r\n").encode() + body


async def send_once(port: int, raw: bytes) -> tuple[int, float, bytes]:
    """One request; the answer is read while the body is still being written, as a browser does, so an answer
    sent before the whole body arrived is seen (and the rest of the body is not pushed into a closed socket)."""
    started = time.perf_counter()
    reader, writer = await asyncio.open_connection("127.0.0.1", port)

    async def write() -> None:
        try:
            writer.write(raw)
            await writer.drain()
        except (ConnectionError, OSError):
            pass  # the server answered and closed before the whole body was written

    sending = asyncio.create_task(write())
    data = b""
    try:
        while chunk := await reader.read(65536):
            data += chunk
    except (ConnectionError, OSError):
        pass
    sending.cancel()
    writer.close()
    elapsed = time.perf_counter() - started
    return status_of(data), elapsed, data.split(b"\r\n\r\n", 1)[-1]


def status_of(data: bytes) -> int:
    try:
        return int(data.split(b" ", 2)[1])
    except (IndexError, ValueError):
        return 0  # no answer at all: a reset connection


def probe_healthz(port: int, duration_s: float, period_s: float) -> list[float]:
    """/healthz every `period_s` from a process of its own (`_timed`): the load generator's event loop, busy
    with its other requests, would otherwise count its own stalls as the server's latency."""
    answers = timed(port, raw_request(f"127.0.0.1:{port}", "GET", "/healthz"), duration_s, period_s)
    return [elapsed if status == 200 else float("inf") for status, elapsed, _ in answers]


def timed(port: int, raw: bytes, duration_s: float, period_s: float) -> list[tuple[int, float, bytes]]:
    """One request every `period_s` from a process of its own, with blocking sockets (as `_probe`): the
    refusals' budget is the server's answer time, which the load generator's loop, busy with 25 MB bodies,
    would otherwise add its own stalls to (measured: 1.6 s in the generator for a 0.5 s check)."""
    seen: list[tuple[int, float, bytes]] = []
    stop = time.monotonic() + duration_s
    while time.monotonic() < stop:
        started = time.perf_counter()
        data = b""
        with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
            try:
                sock.sendall(raw)
                while chunk := sock.recv(65536):
                    data += chunk
            except OSError:
                pass  # the server answered and closed before the whole body was written
        elapsed = time.perf_counter() - started
        seen.append((status_of(data), elapsed, data.split(b"\r\n\r\n", 1)[-1]))
        time.sleep(max(0.0, period_s - elapsed))
    return seen
