"""``station keys``: generate the CURVE key pairs that tcp endpoints require."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from station.bus import add_client_key, generate_keys, keys_dir


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("keys", help="generate CURVE keys for tcp endpoints")
    p.add_argument("--dir", type=Path, default=None,
                   help="key directory (default ~/.config/station/keys)")
    p.add_argument("--force", action="store_true", help="replace existing keys")
    p.add_argument("--json", action="store_true", help="print the paths as JSON")
    p.add_argument("--client", metavar="NAME",
                   help="add a key pair of its own for one driver (client-NAME.key, "
                        "authorised; revoke by deleting authorized/client-NAME.key); the "
                        "server keys must exist")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    directory = args.dir or keys_dir()
    if args.client:
        public = add_client_key(args.client, args.dir, force=args.force)
        if args.json:
            json.dump({"client": str(public)}, sys.stdout)
            sys.stdout.write("\n")
        else:
            print(f"client key {public} written and authorised; run the driver with "
                  f"--client-key {args.client} (copy {public.name}_secret and server.key "
                  "to its machine)")
        return 0
    paths = generate_keys(args.dir, force=args.force)
    if args.json:
        json.dump({k: str(v) for k, v in paths.items()}, sys.stdout)
        sys.stdout.write("\n")
    else:
        print(f"keys written to {directory} (secret keys mode 0600, directory 0700)")
        print(f"server public key: {paths['server']}")
        print(f"client public key: {paths['client']} (authorised in {paths['authorized']})")
        print("copy client.key_secret and server.key to each machine that connects over tcp")
    return 0
