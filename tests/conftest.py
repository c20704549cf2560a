"""Fixtures shared by the test folders."""

import pytest


@pytest.fixture()
def run(capsys):
    """Run the ``rigsim`` command line in this process: ``run(*argv) -> (exit code, stdout, stderr)``."""
    import rigsim.cli as cli

    def _run(*argv):
        try:
            cli.main(list(map(str, argv)))
            code = 0
        except SystemExit as e:
            code = e.code or 0
        out = capsys.readouterr()
        return code, out.out, out.err

    return _run
