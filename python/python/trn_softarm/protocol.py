"""The CAN protocol's frames and candump logs as messages, through the Rust decoder (the
receivers' own reassembly: segmented messages on CAN 2.0, whole ones on CAN FD, and every
kind the protocol has).

Each frame becomes a dict: ``index``, ``timestamp_us``, ``id``, ``fd``, ``data`` (hex),
``what`` (``message``, ``segment`` or ``undecoded``) and, by ``what``, ``message``
(``kind``, ``node``, ``fields``: the message's fields with their values), ``segment``
(``kind``, ``index``, ``count``, ``transfer``: a part of a message that a later frame
completes) or ``error`` (why the frame carries no message). The summary counts frames,
messages and undecoded frames (frames that are part of no decoded message).
"""

import json
from dataclasses import dataclass, field
from os import PathLike
from typing import List, Union

from . import _native


@dataclass
class Decoded:
    """A decoded log: one entry a frame, the lines that were no frame, the counts."""

    frames: List[dict]
    bad_lines: List[dict] = field(default_factory=list)
    summary: dict = field(default_factory=dict)

    @property
    def messages(self):
        """The messages, in order (a segmented message once, at its last segment)."""
        return [f["message"] for f in self.frames if f["what"] == "message"]

    @property
    def undecoded(self):
        """The frames that are part of no decoded message, and the lines that were no frame."""
        return [f for f in self.frames if f["what"] == "undecoded"] + self.bad_lines


def _load(text):
    d = json.loads(text)
    return Decoded(d["frames"], d["bad_lines"], d["summary"])


def decode_candump(log: Union[str, PathLike]) -> Decoded:
    """Decodes a candump log (``candump -l``), given as a path or as its text."""
    if isinstance(log, PathLike) or ("\n" not in log and not log.lstrip().startswith("(")):
        with open(log, encoding="ascii", errors="replace") as f:
            log = f.read()
    return _load(_native.decode_candump(log))


def decode_frames(frames) -> Decoded:
    """Decodes frames in the order received: each ``(can_id, data)`` or ``(can_id, data,
    fd)`` or ``(can_id, data, fd, timestamp_us)``; or python-can ``Message`` objects
    (``arbitration_id``, ``data``, ``is_fd``, ``timestamp`` in seconds)."""
    rows = []
    for i, f in enumerate(frames):
        if hasattr(f, "arbitration_id"):
            rows.append((f.arbitration_id, bytes(f.data), bool(f.is_fd), int(round(f.timestamp * 1e6))))
            continue
        can_id, data, *rest = f
        fd = bool(rest[0]) if rest else False
        t = int(rest[1]) if len(rest) > 1 else i * 1000
        rows.append((int(can_id), bytes(data), fd, t))
    return _load(_native.decode_frames(rows))


class Listener:
    """A python-can listener that decodes the protocol as frames arrive: hand it to
    ``can.Notifier(bus, [listener])`` (or call it with each ``can.Message``). A segmented
    message is reassembled across frames, as the receivers do; each frame's entry (the dict
    of :func:`decode_frames`) is kept in ``entries`` (the last ``keep``), each whole
    message in ``messages`` and handed to ``on_message`` when given. python-can itself is
    not needed to use it: any object with ``arbitration_id``, ``data``, ``is_fd`` and
    ``timestamp`` (seconds) is a frame.

    ``counts()`` gives ``(frames, messages, undecoded)`` so far."""

    def __init__(self, on_message=None, keep=10_000):
        self._dec = _native.StreamDecoder()
        self.on_message = on_message
        self.keep = int(keep)
        self.entries = []
        self.messages = []
        self.errors = []

    def on_message_received(self, msg):
        """python-can's callback: decode one received frame."""
        t = msg.timestamp if msg.timestamp is not None else 0.0
        entry = json.loads(
            self._dec.push(int(msg.arbitration_id), bytes(msg.data), bool(msg.is_fd), int(round(t * 1e6)))
        )
        self.entries.append(entry)
        del self.entries[: -self.keep]
        if entry["what"] == "message":
            self.messages.append(entry["message"])
            del self.messages[: -self.keep]
            if self.on_message is not None:
                self.on_message(entry["message"])

    __call__ = on_message_received

    def on_error(self, exc):
        """python-can's callback when the bus fails: kept in ``errors``."""
        self.errors.append(exc)

    def stop(self):
        """python-can's callback when the notifier stops (nothing to release)."""

    def counts(self):
        """``(frames, messages, undecoded)`` so far."""
        return self._dec.counts()
