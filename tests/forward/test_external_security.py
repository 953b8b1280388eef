"""ExternalModel security: no shell for parameters or paths, each run confined to its work
folder, output size limited; no pickle is ever loaded from a user's file."""

from __future__ import annotations

import io
import json
import os
import pickle
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.forward import ExternalModel, ExternalModelError
from torchshm.forward.files import read_strains

X = np.linspace(0.0, 1.0, 4)
LOADS = np.array([10.0, 20.0])
HOSTILE = "$(touch PWNED); `touch PWNED`; touch PWNED #"


def _script(tmp_path: Path, body: str) -> str:
    path = tmp_path / "program.py"
    path.write_text(
        "import json, os, sys\nimport numpy as np\n"
        "p = json.load(open(os.environ['TORCHSHM_PARAMS']))\n" + body, encoding="utf-8"
    )
    return str(path)


GOOD = "np.savez('strains.npz', strain=np.full((len(p['loads']), len(p['x'])), sum(p['theta_p'])))\n"


def test_hostile_names_and_workdir_never_reach_a_shell(tmp_path: Path) -> None:
    workdir = tmp_path / HOSTILE.replace("/", "_")
    model = ExternalModel([sys.executable, _script(tmp_path, GOOD)], X, LOADS, workdir=workdir,
                          names=[HOSTILE, "b"], keep="all")
    out = model(torch.tensor([1.0, 2.0], dtype=torch.float64))
    assert torch.all(out == 3.0)
    assert not list(tmp_path.rglob("PWNED")) and not Path("PWNED").exists()
    [folder] = list(workdir.glob("run-*"))
    assert json.loads((folder / "params.json").read_text())["names"] == [HOSTILE, "b"]


def test_shell_command_gets_paths_through_the_environment_only(tmp_path: Path) -> None:
    workdir = tmp_path / "a dir; touch PWNED"
    command = f'{sys.executable} {_script(tmp_path, GOOD)} "$TORCHSHM_PARAMS"'
    out = ExternalModel(command, X, LOADS, workdir=workdir)(torch.tensor([1.0, 1.0], dtype=torch.float64))
    assert torch.all(out == 2.0) and not list(tmp_path.rglob("PWNED"))


def test_each_run_works_in_its_own_folder(tmp_path: Path) -> None:
    body = "open('mark.txt', 'w').write(os.getcwd())\n" + GOOD
    model = ExternalModel([sys.executable, _script(tmp_path, body)], X, LOADS, workdir=tmp_path / "runs",
                          keep="all")
    model(torch.tensor([[1.0, 1.0], [2.0, 2.0]], dtype=torch.float64))
    folders = sorted((tmp_path / "runs").glob("run-*"))
    assert len(folders) == 2
    for folder in folders:
        assert (folder / "mark.txt").read_text() == str(folder)


def test_strain_file_linking_outside_the_work_folder_is_refused(tmp_path: Path) -> None:
    secret = tmp_path / "secret.npz"
    np.savez(secret, strain=np.zeros((2, 4)))
    body = f"os.symlink({str(secret)!r}, 'strains.npz')\n"
    model = ExternalModel([sys.executable, _script(tmp_path, body)], X, LOADS, workdir=tmp_path / "runs")
    with pytest.raises(ExternalModelError, match="is a link; a run may only write inside its work folder"):
        model.run(np.array([1.0, 1.0]))


def test_a_run_writing_gigabytes_is_stopped_at_the_limit(tmp_path: Path) -> None:
    body = "f = open('huge.bin', 'wb')\nfor _ in range(64):\n    f.write(b'0' * (1 << 20))\n"
    model = ExternalModel([sys.executable, _script(tmp_path, body)], X, LOADS,
                          workdir=tmp_path / "runs", max_output_bytes=1 << 20)
    with pytest.raises(ExternalModelError, match=r"over max_output_bytes=1048576"):
        model.run(np.array([1.0, 1.0]))
    [folder] = list((tmp_path / "runs").glob("run-*"))
    assert (folder / "huge.bin").stat().st_size <= 1 << 20


def test_output_limit_is_checked(tmp_path: Path) -> None:
    for bad in (0, -1, 1.5, True):
        with pytest.raises(ValueError, match="max_output_bytes must be a positive integer or None"):
            ExternalModel(["true"], X, LOADS, max_output_bytes=bad)


class _Payload:
    """Unpickling this runs code: it must never happen."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def test_strain_file_holding_a_pickle_is_refused_without_running_it(tmp_path: Path) -> None:
    marker = tmp_path / "EXECUTED"
    path = tmp_path / "strains.npz"
    buffer = io.BytesIO()
    np.save(buffer, np.array([_Payload(marker)], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("strain.npy", buffer.getvalue())
    with pytest.raises(ValueError):
        read_strains(path, X, LOADS)
    assert not marker.exists()


def test_surrogate_file_holding_a_pickle_is_refused_without_running_it(tmp_path: Path) -> None:
    from torchshm.surrogate.surrogate import load_surrogate

    marker = tmp_path / "EXECUTED"
    path = tmp_path / "surrogate.pt"
    torch.save({"state": _Payload(marker)}, path)
    with pytest.raises(ValueError, match="surrogate.pt"):
        load_surrogate(path)
    assert not marker.exists()


def test_spool_file_holding_a_pickle_is_not_run(tmp_path: Path) -> None:
    from torchshm.storage import EvaluationStore

    store = EvaluationStore(tmp_path / "s.db")
    store.spool_folder.mkdir(parents=True, exist_ok=True)
    marker = tmp_path / "EXECUTED"
    (store.spool_folder / "x.npz").write_bytes(pickle.dumps(_Payload(marker)))
    try:
        store.ingest()
    except Exception:  # noqa: BLE001 - refusing is fine; running the payload is not
        pass
    assert not marker.exists()


def test_store_row_holding_a_pickle_is_dropped_not_run(tmp_path: Path) -> None:
    import sqlite3

    from torchshm.storage import EvaluationStore

    store = EvaluationStore(tmp_path / "s.db")
    marker = tmp_path / "EXECUTED"
    blob = pickle.dumps(_Payload(marker))
    with sqlite3.connect(store.path) as con:
        con.execute(
            "INSERT INTO evaluations (model, theta_key, status, outputs, n_loads, n_points, checksum) "
            "VALUES ('m', 'k', 'ok', ?, 1, ?, 'x')", (blob, len(blob) // 8),
        )
    assert store.lookup("m", ["k"]) == {} and store.count("m") == 0  # damaged: dropped
    assert not marker.exists()
