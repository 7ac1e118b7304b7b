"""The protocol's listener for python-can: frames handed to it one at a time (as a
``can.Notifier`` hands them) give the messages the whole-log decoder gives, a segmented
message reassembled across calls.

    pytest python/tests/test_listener.py
"""

import importlib.util
from types import SimpleNamespace

import pytest

from trn_softarm import Listener, decode_frames

# the first frames of a training's candump log: a store command, then a TablesStatus in
# four segments on CAN 2.0
FRAMES = [
    (0x381, "0000000000"),
    (0x391, "0015009A77030021"),
    (0x391, "01B7F7F700000000"),
    (0x391, "0200000000000000"),
    (0x391, "0300E4765315"),
]


def frames():
    return [
        SimpleNamespace(arbitration_id=i, data=bytes.fromhex(d), is_fd=False, timestamp=1.0 + k * 0.001)
        for k, (i, d) in enumerate(FRAMES)
    ]


def test_frames_one_at_a_time_give_the_messages_of_the_whole_log():
    """Fails if a segment is taken for a message, the reassembled message differs from the
    whole-log decoder's, the callback misses it, or the counts are off."""
    heard = []
    listener = Listener(on_message=heard.append)
    for f in frames():
        listener(f)
    whole = decode_frames(frames())
    assert listener.messages == whole.messages
    assert [m["kind"] for m in heard] == ["StoreCommand", "TablesStatus"]
    assert heard[1]["fields"]["image_len"] == 227226
    assert [e["what"] for e in listener.entries] == ["message"] + ["segment"] * 3 + ["message"]
    assert listener.counts() == (5, 2, 0)


def test_a_message_missing_segments_is_counted_undecoded_and_memory_is_bounded():
    listener = Listener(keep=2)
    for f in frames()[:3]:
        listener.on_message_received(f)
    assert listener.counts() == (3, 1, 2)
    assert len(listener.entries) == 2


@pytest.mark.skipif(importlib.util.find_spec("can") is None, reason="python-can is not installed")
def test_a_python_can_notifier_feeds_it_from_a_bus():
    """Fails if python-can's Notifier cannot use it, or a message sent on a virtual bus is
    not decoded whole."""
    import can

    with can.Bus(interface="virtual", channel="trn-test", receive_own_messages=False) as rx, can.Bus(
        interface="virtual", channel="trn-test"
    ) as tx:
        listener = Listener()
        notifier = can.Notifier(rx, [listener], timeout=0.05)
        try:
            for i, d in FRAMES:
                tx.send(can.Message(arbitration_id=i, data=bytes.fromhex(d), is_extended_id=False))
            import time

            deadline = time.time() + 5
            while len(listener.messages) < 2 and time.time() < deadline:
                time.sleep(0.01)
        finally:
            notifier.stop()
    assert [m["kind"] for m in listener.messages] == ["StoreCommand", "TablesStatus"]
