"""The check every test of a faulty model file makes: ``gpmegen build`` of the file refuses it
with one line naming the file, the field and the problem, and writes nothing."""

from __future__ import annotations

from gpmegen.cli import main


def refused_in_one_line(path, text: str, change: tuple, field: str, message: str, capsys) -> None:
    """Write ``text`` with ``change`` (old, new) made to ``path`` and check that building it is
    refused so; ``old`` must be in ``text``, so that a stale case fails instead of passing."""
    assert change[0] in text, change[0]
    path.write_text(text.replace(*change))
    out = path.parent / "out"
    assert main(["build", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{path.name}:" in err and f": {field}: " in err and message in err, err
    assert err.count("\n") == 1 and not out.exists()
