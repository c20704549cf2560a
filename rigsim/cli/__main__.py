"""``python -m rigsim.cli``."""

from rigsim.cli import main

main()
