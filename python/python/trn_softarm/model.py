"""The arm's robot description from a plant configuration, on standard output or into a
file::

    python -m trn_softarm.model [--config NAME|FILE] [--format urdf|mjcf] [--out FILE]

URDF (metres, radians) by default, MuJoCo's MJCF with ``--format mjcf``; the configuration
is a built-in plant (``realistic``, the default, ``ideal``, ``aging``, ``realistic-aging``)
or a TOML file. The same text as :func:`trn_softarm.arm_model`.
"""

import argparse
import pathlib
import sys

from ._native import arm_model


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m trn_softarm.model", description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="realistic", help="a built-in plant or a TOML file (default: realistic)")
    ap.add_argument("--format", choices=["urdf", "mjcf"], default="urdf")
    ap.add_argument("--out", type=pathlib.Path, help="write here instead of standard output")
    args = ap.parse_args(argv)
    try:
        text = arm_model(args.config, args.format)
    except ValueError as e:
        ap.exit(1, f"{ap.prog}: error: {e}\n")
    if args.out is None:
        sys.stdout.write(text)
    else:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
