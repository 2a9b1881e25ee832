"""The `drive` console command: the Rust command line, run in this process by the
extension module (the same code as the `drive` binary that `cargo build` makes)."""

import os
import signal
import sys

from . import _native


def main(argv=None):
    """Runs `drive` with `argv` (default: this process's arguments) and exits with its
    status: 0 on success, 1 on an error, 2 on a usage error."""
    args = sys.argv[1:] if argv is None else list(argv)
    # Ctrl-C ends the command as it ends the binary (Python's handler would wait for the
    # Rust code to return first).
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    # A stream closed at start is None in Python (`drive list >&-`): the command line
    # reports a write it cannot make itself.
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
    # Strings as Python decoded them; the extension encodes them back with the file
    # system's encoding (a path that is not UTF-8 stays the same path).
    status = _native.run_cli(["drive", *(os.fspath(a) for a in args)])
    sys.exit(status)


if __name__ == "__main__":
    main()
