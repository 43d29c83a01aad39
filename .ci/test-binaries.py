#!/usr/bin/env python3
"""Lists the test executables of a `cargo test --no-run --message-format=json` build (stdin).

One line per test binary, `PACKAGE_DIR<TAB>EXECUTABLE`, sorted: `make test` runs them straight from
the list (`make rust-test PREBUILT=1`), beside clippy, which holds cargo's build lock (a `cargo test`
would wait for it). Each binary runs in its package's directory, as `cargo test` runs it.
"""

import json
import os
import sys

rows = set()
for line in sys.stdin:
    msg = json.loads(line)
    if (
        msg.get("reason") == "compiler-artifact"
        and msg["profile"]["test"]
        and msg.get("executable")
    ):
        rows.add((os.path.dirname(msg["manifest_path"]), msg["executable"]))
if not rows:
    sys.exit("test-binaries: the build listed no test executable")
for package_dir, executable in sorted(rows):
    print(f"{package_dir}\t{executable}")
