#!/usr/bin/env python3
"""Decode a candump log with trn.dbc (cantools) and check it against the expectations.

usage: decode_candump.py trn.dbc traffic.log traffic.expected.jsonl

Every frame whose id is in the DBC must have an expectation and decode to exactly the
expected signal values (raw integers; enums and bools by value); every other frame must be
of an id the DBC declares segmented (network attribute TrnSegmented), a segment of its
message (the index within its count) or, on CAN FD, one frame of it. Exits 1 on any mismatch.
"""
import json
import re
import sys

import cantools

LINE = re.compile(r"^\((\d+)\.(\d{6})\) (\S+) ([0-9A-Fa-f]{3})(##?)([0-9A-Fa-f]*)$")


def main(dbc_path, log_path, expected_path):
    db = cantools.database.load_file(dbc_path)
    ids = {m.frame_id for m in db.messages}
    segmented = {}
    for entry in db.dbc.attributes["TrnSegmented"].value.split(";"):
        can_id, kind, length, count = entry.split()
        segmented[int(can_id, 16)] = (kind, int(length), int(count))
    if ids & segmented.keys():
        print(f"ids both single-frame and segmented: {sorted(ids & segmented.keys())}")
        return 1
    expected = {}
    with open(expected_path) as f:
        for line in f:
            if line.strip():
                e = json.loads(line)
                expected[e["line"]] = e
    errors = 0
    decoded = skipped = 0
    with open(log_path) as f:
        lines = [l.rstrip("\n") for l in f if l.strip()]
    for n, line in enumerate(lines):
        m = LINE.match(line)
        if not m:
            print(f"line {n}: not candump: {line!r}")
            errors += 1
            continue
        can_id = int(m.group(4), 16)
        data = m.group(6)
        if m.group(5) == "##":
            data = data[1:]  # FD flags nibble
        payload = bytes.fromhex(data)
        if can_id not in ids:
            if n in expected:
                print(f"line {n}: id {can_id:#x} expected in the DBC")
                errors += 1
            elif can_id not in segmented:
                print(f"line {n}: id {can_id:#x} neither a DBC message nor declared segmented")
                errors += 1
            elif m.group(5) == "#" and (payload[0] & 0x0F) >= segmented[can_id][2]:
                print(f"line {n}: segment {payload[0] & 0x0F} of a {segmented[can_id][2]}-segment {segmented[can_id][0]}")
                errors += 1
            elif m.group(5) == "##" and len(payload) < segmented[can_id][1] + 4:
                print(f"line {n}: FD {segmented[can_id][0]} of {len(payload)} bytes")
                errors += 1
            skipped += 1
            continue
        want = expected.get(n)
        if want is None:
            print(f"line {n}: no expectation for DBC id {can_id:#x}")
            errors += 1
            continue
        if want["id"] != can_id:
            print(f"line {n}: id {can_id:#x}, expected {want['id']:#x}")
            errors += 1
            continue
        got = db.decode_message(can_id, payload, decode_choices=False, scaling=True)
        got = {k: int(v) for k, v in got.items()}
        if got != want["signals"]:
            print(f"line {n}: {db.get_message_by_frame_id(can_id).name}: got {got}, want {want['signals']}")
            errors += 1
        decoded += 1
    if decoded != len(expected):
        print(f"decoded {decoded} messages, {len(expected)} expected")
        errors += 1
    names = {db.get_message_by_frame_id(e["id"]).name for e in expected.values()}
    print(f"cantools {cantools.__version__}: {decoded} single-frame messages decoded "
          f"({len(names)} distinct DBC messages of {len(db.messages)}), {skipped} frames of declared "
          f"segmented kinds ({len(segmented)} ids) checked, "
          f"{errors} errors")
    return 1 if errors else 0


if __name__ == "__main__":
    if len(sys.argv) != 4:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(*sys.argv[1:]))
