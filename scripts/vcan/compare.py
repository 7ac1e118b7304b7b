#!/usr/bin/env python3
"""Checks the VM's results: the learning curves over vcan equal the in-process ones bit for
bit (same seed, the bus carries the same bytes), and the candump log decodes with the DBC.
usage: compare.py OUTDIR DBC"""
import json, struct, sys

CURVES = ["stage1_error_px", "stage2_error_px", "combined_error_px", "fine_moves", "fine_moves_stage2"]

def bits(x):
    return None if x is None else struct.unpack("<I", struct.pack("<f", x))[0] if isinstance(x, float) else x

def same_curves(a, b, label):
    ra, rb = json.load(open(a)), json.load(open(b))
    ok = True
    for key in CURVES:
        va, vb = [bits(x) for x in ra[key]], [bits(x) for x in rb[key]]
        if not va or va != vb:
            ok = False
            first = next((i for i, (x, y) in enumerate(zip(va, vb)) if x != y), None)
            print(f"FAIL {label}: {key} differs (lengths {len(va)}/{len(vb)}, first difference at trial {first})")
    if ok:
        n = len(ra["stage1_error_px"])
        print(f"ok   {label}: {n} trials, curves bit-identical; final error {ra['final_error_px']:.4f} px both")
    return ok

def decode_log(log, dbc):
    import cantools
    db = cantools.database.load_file(dbc)
    ids = {m.frame_id for m in db.messages}
    decoded, skipped, pressure = 0, 0, 0
    for line in open(log):
        line = line.strip()
        if not line:
            continue
        _, _, frame = line.split(" ", 2)
        fd = "##" in frame
        ident, data = frame.split("##" if fd else "#", 1)
        if fd:
            data = data[1:]
        ident, data = int(ident, 16), bytes.fromhex(data)
        if ident not in ids:
            skipped += 1  # segments of long messages: not in the DBC by design (SPEC.md)
            continue
        msg = db.get_message_by_frame_id(ident)
        if len(data) != msg.length:
            skipped += 1
            continue
        values = msg.decode(data)
        decoded += 1
        if msg.name.startswith("PressureCommand"):
            raw = [v for k, v in values.items() if k.lower().endswith("raw")]
            assert raw and 0 <= raw[0] <= 4095, (msg.name, values)
            pressure += 1
    ok = decoded > 0 and pressure > 0
    print(f"{'ok  ' if ok else 'FAIL'} candump {log}: {decoded} frames decoded with the DBC "
          f"({pressure} pressure commands in 0..4095), {skipped} segment frames skipped")
    return ok

def tables(out):
    """The tables' round trip over vcan0 (tests.sh checks the bytes; this reports them)."""
    try:
        t = json.load(open(f"{out}/tables.json"))
    except (OSError, ValueError) as e:
        print(f"FAIL tables over vcan: no result ({e})")
        return False
    ok = t["bytes"] > 200_000 and "--reset-tables" in t["refusal"]
    print(f"{'ok  ' if ok else 'FAIL'} tables over vcan: {t['bytes']} bytes written into controller-node and "
          f"read back bit-identical ({t['write_and_read_s']} s), restored after its restart and read again "
          f"({t['restored_eval_and_read_s']} s); a training run refused: {t['refusal'][:90]}...")
    return ok

def main(out, dbc):
    ok = same_curves(f"{out}/inproc.json", f"{out}/vcan.json", "vcan vs in-process (CAN 2.0)")
    ok &= same_curves(f"{out}/inproc-fd.json", f"{out}/vcan-fd.json", "vcan vs in-process (CAN FD)")
    ok &= decode_log(f"{out}/vcan.log", dbc)
    ok &= tables(out)
    sys.exit(0 if ok else 1)

if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
