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


#: A seal's physical parameters for ``roughflow leak`` on a scan (steel pair, water, 2 mm x
#: 60 mm), three rows from 10 MPa to 1 GPa.
LEAK_ARGS = ["--modulus", "200GPa", "--pressures", "10MPa:1GPa:3", "--fluid-pressure", "1MPa",
             "--viscosity", "1mPa.s", "--seal-width", "2mm", "--seal-length", "60mm"]
