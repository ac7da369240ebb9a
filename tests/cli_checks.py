"""What the command-line tests share: a command that must be refused before any work."""

from __future__ import annotations

import pytest

from roughflow.cli import main


def refused(argv: list[str], capsys, *names: str) -> str:
    """Run ``argv``; it must exit 2 (an input error) with a message naming every one of
    ``names``. Returns the message."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    for name in names:
        assert name in err, (name, err)
    return err
