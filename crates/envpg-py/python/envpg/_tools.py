"""``python -m envpg._tools``: the ``envpg`` tools (oracle, evaluate, …) with the Python
environments, run by :func:`envpg.oracle` in a child process."""

import sys

from envpg import _native, _run


def main() -> None:
    _run.IN_RUN_PROCESS = True
    sys.exit(_native.tools_main(["envpg", *sys.argv[1:]]))


if __name__ == "__main__":
    main()
