"""``python -m envpg._launch``: the ``envpg-launch`` program with the Python environments, as
the learner and worker processes of a run started from Python (and usable by hand)."""

import sys

from envpg import _native
from envpg._run import DISPLAY, PROGRAM


def main() -> None:
    sys.exit(_native.launch_main(["envpg-launch", *sys.argv[1:]], PROGRAM, DISPLAY))


if __name__ == "__main__":
    main()
