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


def test_the_command_line_loads_without_the_methods_libraries() -> None:
    """A refused command line (a config error, exit 2) imports neither the methods' libraries
    nor scipy.stats: about 4 s of an 8 s refusal (docs/benchmarks.md, "The main job")."""
    import subprocess
    import sys

    heavy = ("arviz", "sklearn", "emcee", "pyvbmc", "gpytorch", "matplotlib", "xarray", "scipy.stats")
    code = ("import sys, torchshm.cli.identify, torchshm.inference.peer_errors; "
            f"print([m for m in {heavy!r} if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_inference_exports_load_on_first_use() -> None:
    import torchshm.inference as inference

    assert set(inference.__all__) <= set(dir(inference))
    assert inference.identify is torchshm.identify
    with pytest.raises(AttributeError, match="has no attribute 'identfy'"):
        inference.identfy  # noqa: B018
