"""Reading the Language Server Protocol's framed messages from a byte stream, whatever comes.

A message is header lines (``Content-Length: N`` among them), an empty line, then N bytes of
JSON.  :class:`Framing` reads one at a time and survives any framing: a header block without a
usable length (``Content-Length: -5``, ``abc``, a length over :data:`MAX_BODY`, a header line
longer than :data:`MAX_HEADER`) is reported and skipped up to the next ``Content-Length:``, so
the messages after it (``shutdown``, ``exit``) are still read.  No protocol types here.
"""

from __future__ import annotations

#: the longest message body accepted (bytes): a document 100 times the analysed limit, in JSON
MAX_BODY = 64 * 1024 * 1024
#: the longest header block (bytes)
MAX_HEADER = 64 * 1024
_MARK = b"content-length:"


class Framing:
    """Messages from a binary stream (one with ``read1``, such as ``sys.stdin.buffer``)."""

    def __init__(self, stream) -> None:
        self._read = getattr(stream, "read1", None) or stream.read
        self._buffer = bytearray()
        self._eof = False

    def _fill(self) -> bool:
        if self._eof:
            return False
        chunk = self._read(1 << 16)
        if not chunk:
            self._eof = True
            return False
        self._buffer += chunk
        return True

    def _line(self) -> bytes | None:
        """One header line without its end; None at the end of the stream or for an overlong line."""
        while True:
            end = self._buffer.find(b"\n")
            if end >= 0:
                line = bytes(self._buffer[:end])
                del self._buffer[: end + 1]
                return line.rstrip(b"\r")
            if len(self._buffer) > MAX_HEADER or not self._fill():
                return None

    def _resync(self) -> None:
        """Drop bytes up to the next ``Content-Length:`` (any case), or all of them."""
        while True:
            at = self._buffer.lower().find(_MARK)
            if at >= 0:
                del self._buffer[:at]
                return
            keep = len(_MARK) - 1
            if len(self._buffer) > keep:
                del self._buffer[: len(self._buffer) - keep]
            if not self._fill():
                self._buffer.clear()
                return

    def next(self) -> tuple[bytes | None, str | None] | None:
        """``(body, None)`` for a message, ``(None, what was wrong)`` for a header block that was
        skipped, None at the end of the stream."""
        headers: list[bytes] = []
        while True:
            line = self._line()
            if line is None:
                if self._eof:
                    return None
                self._resync()
                return None, f"a header line longer than {MAX_HEADER} bytes"
            if line.strip():
                headers.append(line)
                if sum(map(len, headers)) > MAX_HEADER:
                    self._resync()
                    return None, f"a header block longer than {MAX_HEADER} bytes"
                continue
            if headers:
                break  # the empty line after the headers
        length, problem = _content_length(headers)
        if problem is not None:
            self._resync()
            return None, problem
        while len(self._buffer) < length and self._fill():
            pass
        if len(self._buffer) < length:
            missing = length - len(self._buffer)
            self._buffer.clear()
            return None, f"the stream ended {missing} bytes before the end of a {length}-byte message"
        body = bytes(self._buffer[:length])
        del self._buffer[:length]
        return body, None


def _content_length(headers: list[bytes]) -> tuple[int, str | None]:
    shown = b" | ".join(h[:60] for h in headers).decode("utf-8", "replace")
    for h in headers:
        at = h.lower().find(_MARK)  # bytes left before it by a broken message are not a header
        if at >= 0:
            value = h[at + len(_MARK):].strip()
            if not value.isdigit():
                return 0, f"bad message header {shown!r}: Content-Length must be a number of bytes >= 0; skipped"
            length = int(value)
            if length > MAX_BODY:
                return 0, f"message of {length} bytes refused (at most {MAX_BODY}); skipped"
            return length, None
    return 0, f"bad message header {shown!r}: no Content-Length; skipped"
