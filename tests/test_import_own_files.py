"""``roughflow import`` on a file roughflow wrote: a surface file is used as it is, and a
result is no scan. Both were read as plain HDF5 and answered "does not give its length
unit", and a leak file's variables were offered as channels (a user audit)."""

from __future__ import annotations

import pytest
from cli_checks import refused

from roughflow.cli import main
from roughflow.errors import InputError
from roughflow.scan import read_scan


def test_a_surface_file_is_refused_as_already_imported(cli_surface_file):
    with pytest.raises(InputError, match="already a roughflow surface file") as exc:
        read_scan(cli_surface_file, size="1mm", unit="um")
    assert "roughflow surface" in str(exc.value)  # the command that wrote it


def test_a_result_file_is_refused_as_no_scan(cli_surface_file, tmp_path, capsys):
    contact = tmp_path / "c.nc"
    assert main(["contact", str(cli_surface_file), "--pressure", "0.1", "-o",
                 str(contact)]) in (0, None)
    capsys.readouterr()
    refused(["import", str(contact), "-o", str(tmp_path / "s.nc")], capsys,
            "is a roughflow result", "roughflow contact", "not a scan")
    assert not (tmp_path / "s.nc").exists()
