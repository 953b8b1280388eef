"""torchshm._lazy: the packages' lazy exports and their ``dir``."""

from __future__ import annotations

import pytest

import torchshm
import torchshm.casestudy
from torchshm._lazy import lazy_dir


def test_dir_is_the_loaded_names_and_every_export_sorted() -> None:
    namespace = {"loaded": 1, "__name__": "pkg"}
    listing = lazy_dir({"not_imported_yet": "module", "loaded": "module"}, namespace)
    assert listing() == ["__name__", "loaded", "not_imported_yet"]
    namespace["later"] = 2  # the package's globals as they are when dir() is called
    assert "later" in listing()


@pytest.mark.parametrize("package", [torchshm, torchshm.casestudy], ids=lambda p: p.__name__)
def test_the_packages_list_their_exports(package: object) -> None:
    names = dir(package)
    assert names == sorted(names)
    assert set(package.__all__) <= set(names)  # type: ignore[attr-defined]


def test_an_unknown_name_is_an_attribute_error_that_names_it() -> None:
    with pytest.raises(AttributeError, match="'torchshm' has no attribute 'identfy'"):
        torchshm.identfy  # noqa: B018
