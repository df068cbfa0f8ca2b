"""``station udev [--check] [-o FILE]``: the udev rules for supported tablets.

Without options the rules are printed; ``-o FILE`` writes them; ``--check``
compares the installed package's rules file (or ``-o FILE``) with freshly
generated ones and fails (exit 1) when it is stale.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from station.drivers.serial.transport import UsbSerialId
from station.errors import StationError
from station.udev.generate import RULES_PATH, check, generate


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("udev", help="udev rules giving the seat user / station group the tablets")
    p.add_argument("--check", action="store_true",
                   help="check the rules file is up to date (exit 1 if stale)")  # fmt: skip
    p.add_argument("--haptic", metavar="VID:PID[:SERIAL]",
                   help="print the rule giving this serial haptic device its stable symlink "
                        "/dev/station-haptic-… (docs/haptic-protocol.md)")
    p.add_argument("-o", "--output", type=Path, default=None,
                   help="write the rules to this file (default: print them)")  # fmt: skip
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.haptic:
        text = UsbSerialId.parse(args.haptic, "--haptic").udev_rule()
    elif args.check:
        ok, message = check(args.output or RULES_PATH)
        if not ok:
            raise StationError(message)
        print(message)
        return 0
    else:
        text = generate()
    if args.output is None:
        sys.stdout.write(text)
        return 0
    try:
        args.output.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise StationError(f"{args.output}: cannot write ({exc.strerror})") from None
    print(f"wrote {args.output} ({text.count(chr(10))} lines); install with:\n"
          f"  sudo install -m 0644 {args.output} /etc/udev/rules.d/\n"
          "  sudo udevadm control --reload && sudo udevadm trigger")  # fmt: skip
    return 0
