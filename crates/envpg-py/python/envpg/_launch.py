"""``python -m envpg._launch``: the ``envpg-launch`` program with the Python environments, as
the learner and worker processes of a run started from Python (and usable by hand)."""

import sys

from envpg import _native, _run
DISPLAY, PROGRAM = _run.DISPLAY, _run.PROGRAM


def main() -> None:
    _run.IN_RUN_PROCESS = True
    sys.exit(_native.launch_main(["envpg-launch", *sys.argv[1:]], PROGRAM, DISPLAY))


if __name__ == "__main__":
    main()
