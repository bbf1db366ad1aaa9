"""The bytes of a campaign file as text, in the encoding its software wrote.

Tracker software on Windows writes what the machine's code page gives: Leica's and FARO's exports Windows-1252
(`°C`, `µm` in the header), Excel's "Unicode text" UTF-16 with a byte-order mark, newer tools UTF-8 with or
without one. A file is read as UTF-8 when it is valid UTF-8 (which a Windows-1252 text with any byte over 0x7F
almost never is), as UTF-16 when a byte-order mark or the NUL bytes of ASCII in UTF-16 say so, and otherwise as
Windows-1252 (its five undefined bytes as Latin-1), and a note says which.
"""

from __future__ import annotations

import codecs

from service.campaign_io.errors import CampaignFileError

NUL_SHARE = 0.3
"""ASCII text in UTF-16 without a byte-order mark has a NUL in every other byte: more than this share of NULs
among the first bytes, on one parity, marks it (UTF-8 and Windows-1252 text has none)."""
SNIFF_BYTES = 4096


def decode_text(raw: bytes, what: str) -> tuple[str, str | None]:
    """(the text, a note naming the encoding when it was not UTF-8)."""
    if raw.startswith(codecs.BOM_UTF8):
        return _strict(raw[len(codecs.BOM_UTF8) :], "utf-8", what), None
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        return _strict(raw, "utf-16", what), f"{what} was read as UTF-16 (its byte-order mark says so)"
    head = raw[:SNIFF_BYTES]
    if len(head) >= 4:
        even, odd = head[0::2], head[1::2]
        if odd.count(0) > NUL_SHARE * len(odd) and even.count(0) == 0:
            return _strict(raw, "utf-16-le", what), f"{what} was read as UTF-16 (little-endian, no byte-order mark)"
        if even.count(0) > NUL_SHARE * len(even) and odd.count(0) == 0:
            return _strict(raw, "utf-16-be", what), f"{what} was read as UTF-16 (big-endian, no byte-order mark)"
    if b"\x00" in head:
        raise CampaignFileError(f"{what} holds NUL bytes in no text encoding: send the file as text (CSV or TXT)")
    try:
        return raw.decode("utf-8"), None
    except UnicodeDecodeError:
        pass
    return _windows_1252(
        raw
    ), f"{what} is not UTF-8: read as Windows-1252 (the code page Windows tracker software writes)"


def _windows_1252(raw: bytes) -> str:
    """Windows-1252, its five undefined bytes (0x81, 0x8D, 0x8F, 0x90, 0x9D) read as Latin-1, which it extends."""
    try:
        return raw.decode("cp1252")
    except UnicodeDecodeError:
        return "".join(chr(b) if b in UNDEFINED else bytes([b]).decode("cp1252") for b in raw)


UNDEFINED = frozenset({0x81, 0x8D, 0x8F, 0x90, 0x9D})


def _strict(raw: bytes, encoding: str, what: str) -> str:
    try:
        return raw.decode(encoding).removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise CampaignFileError(
            f"{what} is not valid {encoding.upper()} text at byte {exc.start}: save it as UTF-8 (or as the tool "
            "exports it, unchanged)"
        ) from exc
