"""A deadline for a request's headers: the lever uvicorn lacks (slowloris).

uvicorn times out only an idle keep-alive connection (5 s); a client that sends its request line and headers a
byte at a time holds its connection, and a file descriptor, for as long as it likes, and a few hundred such
clients exhaust the server. The body has its deadline in the app (`service.http.guards.BodyGuard`, 408), but no ASGI
middleware runs before the headers are complete, so this one lives in the HTTP protocol: a subclass of uvicorn's
(httptools, else h11) that starts a timer when a connection opens or a new request's first bytes arrive, stops
it when the headers are complete, and when it fires answers 408 and closes the connection.

`python -m service` passes the class to uvicorn (`http=`); `protocol(seconds)` makes one for a deadline.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any

from service.errors import RequestTimeout
from service.http.problems import to_problem

HEADER_TIMEOUT_S = 10.0
"""The default deadline: a request line and headers are at most a few kB, sent in one packet by any client;
10 s leaves room for a slow mobile link and frees the connection of one that trickles."""


def _answer(seconds: float) -> bytes:
    # The same problem document as the app's 408 for a slow body (service.http.problems renders RequestTimeout).
    problem = to_problem(RequestTimeout(f"the request headers did not arrive within {seconds:g} s"))
    body = json.dumps(problem).encode()
    head = (
        "HTTP/1.1 408 Request Timeout\r\ncontent-type: application/problem+json\r\nconnection: close\r\n"
        f"content-length: {len(body)}\r\n\r\n"
    )
    return head.encode() + body


def protocol(seconds: float = HEADER_TIMEOUT_S) -> type[asyncio.Protocol]:
    try:
        from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol as Base  # noqa: PLC0415
    except ImportError:  # uvicorn without httptools: its pure-Python h11 protocol has the same hooks
        from uvicorn.protocols.http.h11_impl import H11Protocol as Base  # type: ignore[assignment]  # noqa: PLC0415

    answer = _answer(seconds)

    class HeaderDeadline(Base):
        header_timeout_s = seconds
        _header_timer: asyncio.TimerHandle | None = None

        def connection_made(self, transport: Any) -> None:
            super().connection_made(transport)
            self._arm()

        def data_received(self, data: bytes) -> None:
            if self._header_timer is None and self._awaiting_headers():
                self._arm()  # the first bytes of the next request on a kept-alive connection
            super().data_received(data)
            if not self._awaiting_headers():
                self._disarm()

        def connection_lost(self, exc: Exception | None) -> None:
            self._disarm()
            super().connection_lost(exc)

        def _awaiting_headers(self) -> bool:
            return self.cycle is None or bool(self.cycle.response_complete)

        def _arm(self) -> None:
            self._disarm()
            self._header_timer = self.loop.call_later(seconds, self._expired)

        def _disarm(self) -> None:
            if self._header_timer is not None:
                self._header_timer.cancel()
                self._header_timer = None

        def _expired(self) -> None:
            self._header_timer = None
            if self._awaiting_headers() and not self.transport.is_closing():
                self.transport.write(answer)
                self.transport.close()

    return HeaderDeadline
