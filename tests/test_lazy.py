"""torchshm._lazy: the packages' lazy exports and their ``dir``."""

from __future__ import annotations

import pytest

import torchshm
import torchshm.casestudy


@pytest.mark.parametrize("package", [torchshm, torchshm.casestudy], ids=lambda p: p.__name__)
def test_dir_lists_every_export_before_it_is_imported(package: object) -> None:
    names = dir(package)
    assert names == sorted(names)
    assert set(package.__all__) <= set(names)  # type: ignore[attr-defined]


def test_an_unknown_name_is_an_attribute_error_that_names_it() -> None:
    with pytest.raises(AttributeError, match="'torchshm' has no attribute 'identfy'"):
        torchshm.identfy  # noqa: B018
