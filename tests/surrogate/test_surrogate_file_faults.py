"""A truncated or damaged surrogate file (.pt): one line naming the file; an interrupted save
keeps the previous file."""

from __future__ import annotations

from pathlib import Path

import pytest

import torchshm
from torchshm.casestudy import shipped_path

SHIPPED = shipped_path()


def test_damaged_surrogate_files(tmp_path: Path) -> None:
    good = tmp_path / "good.pt"
    torchshm.load_surrogate(SHIPPED).save(good)
    data = good.read_bytes()
    assert torchshm.load_surrogate(good).identity == torchshm.load_surrogate(SHIPPED).identity
    cases = {
        "truncated.pt": (data[: len(data) // 2], "not a readable torchshm surrogate file"),
        "garbage.pt": (b"garbage" * 50, "not a readable torchshm surrogate file"),
        # bytes inside the stored tensors: the archive still opens, the checksum catches it
        "flipped.pt": (data[: len(data) // 2] + bytes(64) + data[len(data) // 2 + 64:],
                       "does not match its checksum"),
    }
    for name, (content, message) in cases.items():
        path = tmp_path / name
        path.write_bytes(content)
        with pytest.raises(ValueError, match=message) as error:
            torchshm.load_surrogate(path)
        assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_interrupted_surrogate_save_keeps_the_previous_file(tmp_path: Path) -> None:
    path = tmp_path / "sur.pt"
    sur = torchshm.load_surrogate(SHIPPED)
    sur.save(path)
    before = path.read_bytes()
    (tmp_path / "sur.pt.tmp").mkdir()  # the temporary file cannot be written
    with pytest.raises(OSError, match="cannot write surrogate file"):
        sur.save(path)
    assert path.read_bytes() == before
