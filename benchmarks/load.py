"""A small open-loop HTTP/1.1 load generator on raw asyncio streams.

Python HTTP clients spend a millisecond or more of CPU per request; on a 2-core machine that shares the
cores with the server, that cost shows up as server latency. This one writes pre-built requests on
keep-alive connections and reads responses by Content-Length: tens of microseconds per request.
"""

from __future__ import annotations

import asyncio
import json
import time
from urllib.parse import urlsplit


def request_bytes(host: str, path: str, body: object) -> bytes:
    payload = json.dumps(body).encode()
    head = (
        f"POST {path} HTTP/1.1\r\nHost: {host}\r\nContent-Type: application/json\r\n"
        f"Content-Length: {len(payload)}\r\nConnection: keep-alive\r\n\r\n"
    )
    return head.encode() + payload


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
