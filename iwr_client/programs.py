"""Robot program files as the client sends and writes them: the text the API's JSON takes, and the bytes the
controller gets back in the encoding the file came in.

A program compensation changes only the digits of its targets, so a file written back in the encoding it was read
in keeps every other byte: a KUKA backup's Windows-1252 umlauts, a UTF-8 byte-order mark, a RAPID export in
UTF-16. The JSON body carries text, so the client decodes: UTF-16 when the file starts with its byte-order mark,
UTF-8 (a mark kept aside) when the bytes are UTF-8, and Windows-1252 otherwise (what KUKA's controllers write;
the five bytes that code page leaves undefined are read as Latin-1, so every byte string decodes and encodes back
to itself)."""

from __future__ import annotations

import codecs
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePath

FORMATS = {
    ".src": "krl",
    ".dat": "krl",
    ".sub": "krl",
    ".mod": "rapid",
    ".modx": "rapid",
    ".prg": "rapid",
    ".sys": "rapid",
    ".sysx": "rapid",
    ".script": "urscript",
    ".urscript": "urscript",
    ".csv": "csv",
}
"""A program's format by its file name's extension (any case), as a controller's backup names its files."""

_BOMS = ((codecs.BOM_UTF8, "utf-8"), (codecs.BOM_UTF16_LE, "utf-16-le"), (codecs.BOM_UTF16_BE, "utf-16-be"))
_UNDEFINED_1252 = frozenset({0x81, 0x8D, 0x8F, 0x90, 0x9D})


def format_of(name: str) -> str | None:
    """The format a file name's extension names, or None."""
    return FORMATS.get(PurePath(name).suffix.lower())


_CP1252 = "".join(bytes([b]).decode("latin-1" if b in _UNDEFINED_1252 else "cp1252") for b in range(256))
"""Byte -> character: Windows-1252, Latin-1 for its five undefined bytes (a total, reversible decoding)."""
_CP1252_BYTES = {c: b for b, c in enumerate(_CP1252)}


def _decode_1252(data: bytes) -> str:
    return "".join(map(_CP1252.__getitem__, data))


def _encode_1252(text: str) -> bytes:
    try:
        return bytes(map(_CP1252_BYTES.__getitem__, text))
    except KeyError as missing:
        raise UnicodeEncodeError("cp1252", text, 0, len(text), f"{missing} has no Windows-1252 byte") from None


@dataclass(frozen=True)
class ProgramFile:
    """A program file's name (no directory: the API names files so), its text and how its bytes encode it."""

    name: str
    text: str
    encoding: str
    """utf-8, utf-16-le, utf-16-be or cp1252."""
    bom: bool = False

    @classmethod
    def decode(cls, name: str, data: bytes) -> ProgramFile:
        for mark, encoding in _BOMS:
            if data.startswith(mark):
                return cls(name, data[len(mark) :].decode(encoding), encoding, bom=True)
        try:
            return cls(name, data.decode("utf-8"), "utf-8")
        except UnicodeDecodeError:
            return cls(name, _decode_1252(data), "cp1252")

    @classmethod
    def read(cls, path: str | Path) -> ProgramFile:
        file = Path(path)
        return cls.decode(file.name, file.read_bytes())

    def encode(self, text: str) -> bytes:
        """`text` (this file's compensated text) as bytes in this file's encoding and byte-order mark."""
        if self.encoding == "cp1252":
            return _encode_1252(text)
        mark = {encoding: mark for mark, encoding in _BOMS}[self.encoding] if self.bom else b""
        return mark + text.encode(self.encoding)


def compensated_bytes(
    answer: Mapping[str, object], program: ProgramFile, files: Mapping[str, ProgramFile]
) -> dict[str, bytes]:
    """The files to give the controller, by name: the program (always: it is the compensated program, changed or
    not) and each companion file the answer rewrote, each in the encoding it came in. Companion files the answer
    does not return held no corrected target and are left out (write nothing a controller already has)."""
    out = {program.name: program.encode(str(answer["program"]))}
    rewritten = answer.get("files") or {}
    if isinstance(rewritten, Mapping):
        for name, text in rewritten.items():
            source = files.get(name)
            out[name] = source.encode(str(text)) if source is not None else str(text).encode("utf-8")
    return out
