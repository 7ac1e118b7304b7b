#!/usr/bin/env python3
"""Generate protocol/trn.dbc: every single-frame (<= 8 byte) message of the TRN protocol.

The 11-bit id is (kind << 4) | node; one DBC message per allowed (kind, node) pair.
Layouts are fixed, little endian (see SPEC.md). Run: python3 tools/gen_dbc.py > trn.dbc
A Rust test (tests/dbc.rs) checks the DBC against the crate's id table and lengths.
"""

NODES = {  # code: DBC node name
    1: "Controller", 2: "Servo0", 3: "Servo1", 4: "Servo2", 5: "Servo3", 6: "Servo4",
    8: "CameraProcessor", 10: "Gripper", 11: "Runner",
}
BROADCAST = 15
ANY = [1, 2, 3, 4, 5, 6, 8, 10, 11]
SERVOS = [2, 3, 4, 5, 6]

ENUMS = {
    "EmergencyReason": ["Operator", "HeartbeatLost", "PressureFault", "ControllerFault", "BusFault"],
    "SafeStateReason": ["HeartbeatLost", "Emergency", "Commanded"],
    "SafeStateAction": ["HoldLast", "Vent"],
    "SafeState": ["Normal", "HoldLast", "Vented"],
    "CaptureKind": ["GripperLights", "GripperCentre"],
    "Mode": ["Idle", "Priming", "Training", "Mature"],
    "NodeState": ["Booting", "Operational", "SafeState", "Fault"],
    "Bool": ["false", "true"],
    "GuardOp": ["Reseed", "TableWrite", "StoreErase"],
    "StoreOp": ["Status", "Save", "Erase"],
}

# (signal, start bit, length, enum or None, (min, max), unit)
U8 = lambda name, start, enum=None, rng=(0, 255), unit="": (name, start, 8, enum, rng, unit)
U16 = lambda name, start, rng=(0, 65535), unit="": (name, start, 16, None, rng, unit)
U32 = lambda name, start, unit="": (name, start, 32, None, (0, 4294967295), unit)
BOOL = lambda name, start: (name, start, 8, "Bool", (0, 1), "")
ENUM = lambda name, start, enum: (name, start, 8, enum, (0, len(ENUMS[enum]) - 1), "")

# kind name, code, length, allowed nodes, sender (None = the node itself), signals
KINDS = [
    ("Emergency", 0x01, 1, ANY, None, [ENUM("reason", 0, "EmergencyReason")]),
    ("SafeStateEntered", 0x02, 4, ANY, None, [
        ENUM("reason", 0, "SafeStateReason"), ENUM("action", 8, "SafeStateAction"),
        U16("held_raw", 16, (0, 4095), "raw12")]),
    ("PressureCommand", 0x08, 4, SERVOS, "Controller", [
        U16("seq", 0), U16("raw", 16, (0, 4095), "raw12")]),
    ("ServoStatus", 0x09, 8, SERVOS, None, [
        U16("seq", 0), U16("raw", 16, (0, 4095), "raw12"), U16("applied", 32, (0, 4095), "raw12"),
        BOOL("saturated", 48), ENUM("safe_state", 56, "SafeState")]),
    ("GripperCommand", 0x0A, 1, [10], "Controller", [BOOL("close", 0)]),
    ("GripperStatus", 0x0B, 1, [10], None, [BOOL("closed", 0)]),
    ("CaptureRequest", 0x10, 3, [8], "Controller", [U16("seq", 0), ENUM("what", 16, "CaptureKind")]),
    ("ModeChange", 0x18, 1, [1, BROADCAST], None, [ENUM("mode", 0, "Mode")]),
    ("GuardRequest", 0x1B, 1, [1], "Runner", [ENUM("op", 0, "GuardOp")]),
    ("GuardNonce", 0x1C, 7, [1], None, [
        ENUM("op", 0, "GuardOp"), U32("nonce", 8), U16("window_ms", 40, unit="ms")]),
    ("GraspRequest", 0x23, 4, [1], "Runner", [U32("trial", 0)]),
    ("ErrorReport", 0x30, 6, ANY, None, [U16("code", 0), U32("detail", 16)]),
    ("StoreCommand", 0x38, 5, [1], "Runner", [ENUM("op", 0, "StoreOp"), U32("nonce", 8)]),
    ("TableWriteEnd", 0x3B, 4, [1], "Runner", [U32("image_crc", 0)]),
    ("Heartbeat", 0x70, 2, ANY, None, [U8("counter", 0), ENUM("state", 8, "NodeState")]),
    ("TableReadRequest", 0x78, 2, [1], "Runner", [U16("index", 0)]),
    ("TableWriteAck", 0x7B, 6, [1], None, [U16("next", 0), U32("image_crc", 16)]),
]


# Segmented ("long") kinds: more than 8 bytes, so not DBC messages. On CAN 2.0 each is cut
# into segments (SPEC.md 4.3), on CAN FD sent whole with a CRC-32 (4.2); the DBC lists them
# in the network attribute TrnSegmented ("id kind payload-bytes segments", ";"-separated) and
# says in its comment how to decode them. (kind, code, payload length, nodes)
SEGMENTED = [
    ("Observation", 0x11, 39, [8]),
    ("SessionConfig", 0x19, 17, [1, BROADCAST]),
    ("ConfirmedSessionConfig", 0x1A, 21, [1]),
    ("SupervisedPressure", 0x20, 24, [1]),
    ("Stage1Target", 0x21, 39, [1]),
    ("Stage2Target", 0x22, 23, [1]),
    ("TrialReport", 0x28, 15, [1]),
    ("TablesStatus", 0x39, 21, [1]),
    ("TableWriteBegin", 0x3A, 16, [1]),
    ("TableReadChunk", 0x79, 50, [1]),
    ("TableWriteChunk", 0x7A, 50, [1]),
]


def segments(length):
    """Segments of a payload on CAN 2.0: 6 stream bytes in the first, 7 in each next."""
    return 1 + -(-(length + 4 - 6) // 7)


def sender_of(kind, node, sender):
    if kind == "ModeChange":
        # Runner -> controller; the controller broadcasts the mode to every node.
        return "Runner" if node == 1 else "Controller"
    return sender or NODES[node]


def receivers(kind, node, tx):
    if node == BROADCAST or kind in ("Heartbeat", "Emergency", "SafeStateEntered", "ErrorReport"):
        return ",".join(n for n in NODES.values() if n != tx)
    if node in NODES and NODES[node] != tx:
        return NODES[node]
    return "Runner" if tx != "Runner" else "Controller"


def node_suffix(node):
    return "Broadcast" if node == BROADCAST else NODES[node]


def main():
    out = []
    out.append('VERSION "trn-protocol 1"\n\nNS_ :\n\nBS_:\n')
    out.append("BU_: " + " ".join(NODES.values()) + "\n")
    vals = []
    for kind, code, length, nodes, sender, signals in KINDS:
        for node in nodes:
            can_id = (code << 4) | node
            name = f"{kind}_{node_suffix(node)}"
            tx = sender_of(kind, node, sender)
            rx = receivers(kind, node, tx)
            out.append(f"\nBO_ {can_id} {name}: {length} {tx}\n")
            for sig, start, bits, enum, (lo, hi), unit in signals:
                out.append(
                    f' SG_ {sig} : {start}|{bits}@1+ (1,0) [{lo}|{hi}] "{unit}" {rx}\n'
                )
                if enum:
                    choices = " ".join(f'{i} "{v}"' for i, v in enumerate(ENUMS[enum]))
                    vals.append(f"VAL_ {can_id} {sig} {choices} ;\n")
    out.append("\n")
    out.append(
        'CM_ "TRN CAN protocol. Id = kind << 4 | node. See protocol/SPEC.md. The messages here are '
        "the single-frame kinds. The segmented kinds (attribute TrnSegmented: id, kind, payload "
        "bytes, segments on CAN 2.0) are no DBC messages: on CAN 2.0 a message is cut into "
        "segments sent with its id, byte 0 = transfer << 4 | segment, segment 0 byte 1 = the "
        "payload length, then payload and CRC-32 (SPEC.md 4.3); on CAN FD one frame, payload and "
        "CRC-32 (4.2). Decode them with trn decode LOG or the Python package "
        '(trn_softarm.decode_candump).";\n'
    )
    out.append('BA_DEF_  "TrnSegmented" STRING ;\n')
    out.append('BA_DEF_DEF_  "TrnSegmented" "";\n')
    listed = "; ".join(
        f"0x{(code << 4) | node:03X} {kind} {length} {segments(length)}"
        for kind, code, length, nodes in SEGMENTED
        for node in nodes
    )
    out.append(f'BA_ "TrnSegmented" "{listed}";\n')
    out.extend(vals)
    print("".join(out), end="")


if __name__ == "__main__":
    main()
