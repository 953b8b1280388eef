"""Every Python and shell block of the documentation runs as written (slow: a few minutes).

The pages of :data:`tests.docs_blocks.DOC_FILES` are run in a copy of the repository (so that
what they write stays out of it), with this checkout's ``torchshm`` and a ``.venv`` that is the
test's interpreter. A page's Python blocks run in order in one namespace, in one process; each
shell block runs with ``bash -e``. Markers (``<!-- docs-test: ... -->``, see
:mod:`tests.docs_blocks`) skip a block with its reason, give it a setup, or name the test that
runs it (that test reads the block through the same collector; checked here).

Budgets, kept small so that the whole test fits CI (stated here, applied only where the page
gives none smaller): ``torchshm.identify`` runs VBMC with ``max_fun_evals`` <= 20 and
``n_samples`` <= 2000, emcee with ``n_steps`` <= 60, the emulator with the options of
:data:`CLI_BUDGET` that the page does not set itself (a cap of 8 model runs, 16 walkers, short
chains, 2 error draws: a check that the page's code runs, not that it converges).
``torchshm-identify`` gets the overrides :data:`CLI_BUDGET` of its method, unless the command
sets that key itself. Every block runs with ``TORCHSHM_SMOKE=1``: the benchmark and study
scripts then run with tiny sizes (a check that they run; each says so when it starts).
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.docs_blocks import DOC_FILES, REPO, Block, all_blocks, collect

pytestmark = pytest.mark.slow

#: overrides appended to ``torchshm-identify`` commands, by method
CLI_BUDGET = {
    "vbmc": ["method.max_fun_evals=20", "method.n_samples=2000"],
    "emcee": ["method.n_steps=60", "method.n_walkers=8"],
    "emulator": ["method.max_model_evaluations=8", "method.n_walkers=16", "method.n_steps=30",
                 "method.final_steps=30", "method.n_evidence=1000", "method.error_draws=2"],
    "": ["predict.n=200"],
}

_CLI = '''#!{python}
"""torchshm-identify with the docs test's small budgets (tests/test_docs.py)."""
import sys
from torchshm.cli.identify import main
budget = {budget!r}
args = sys.argv[1:]
given = {{a.split("=", 1)[0].lstrip("+~") for a in args if "=" in a}}
method = next((a.split("=", 1)[1] for a in args if a.startswith("method=")), "emulator")  # the default method of conf/config.yaml
extra = [o for o in budget.get(method, []) + budget[""] if o.split("=", 1)[0] not in given]
main(args + extra)
'''

_PYTHON = '''"""The Python blocks of one page, in order, in one namespace (tests/test_docs.py)."""
import inspect, json, sys, traceback
import torchshm

_identify = torchshm.identify
_default = inspect.signature(_identify).parameters["method"].default


def identify(problem, *args, **options):
    """torchshm.identify with the docs test's budgets."""
    method = args[0] if args else options.get("method", _default)
    if method == "vbmc":
        options["max_fun_evals"] = min(options.get("max_fun_evals") or 20, 20)
        options["n_samples"] = min(options.get("n_samples", 2000), 2000)
    if method == "emcee":
        options["n_steps"] = min(options.get("n_steps", 60), 60)
    if method == "emulator":  # as CLI_BUDGET's, where the block does not set them itself
        for key, value in EMULATOR_BUDGET.items():
            options.setdefault(key, value)
    return _identify(problem, *args, **options)


def main() -> None:
    torchshm.identify = identify
    namespace = {"__name__": "__main__"}
    for block in json.load(open(sys.argv[1])):
        print(f"### docs-test: {block['name']}", flush=True)
        try:
            exec(compile(block["setup"], block["name"] + " (setup)", "exec"), namespace)
            exec(compile(block["code"], block["name"], "exec"), namespace)
        except BaseException:
            traceback.print_exc()
            print(f"### docs-test: {block['name']} failed", flush=True)
            sys.exit(1)


if __name__ == "__main__":  # worker processes started by spawn (Dask) import this file again
    main()
'''


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the repository with a ``.venv`` of the test's interpreter."""
    root = tmp_path_factory.mktemp("docs") / "repo"
    shutil.copytree(REPO, root, ignore=shutil.ignore_patterns(
        ".git", ".venv", "runs", "__pycache__", ".pytest_cache", "*.egg-info"))
    venv = Path(sys.prefix)
    (root / ".venv" / "bin").mkdir(parents=True)
    shutil.copy(venv / "pyvenv.cfg", root / ".venv" / "pyvenv.cfg")
    for lib in ("lib", "lib64"):
        if (venv / lib).exists():
            (root / ".venv" / lib).symlink_to(venv / lib)
    python = root / ".venv" / "bin" / "python"
    python.symlink_to(sys.executable)
    script = root / ".venv" / "bin" / "torchshm-identify"
    script.write_text(_CLI.format(python=python, budget=CLI_BUDGET))
    script.chmod(0o755)
    emulator = {k.split("=")[0].removeprefix("method."): int(k.split("=")[1]) for k in CLI_BUDGET["emulator"]}
    (root / ".docs_test.py").write_text(_PYTHON.replace("EMULATOR_BUDGET", repr(emulator)))
    return root


def _env(root: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"}
    env.update(PATH=f"{root / '.venv' / 'bin'}:{env.get('PATH', '')}", PYTHONPATH=str(root),
               OMP_NUM_THREADS="1", MPLBACKEND="Agg", TORCHSHM_SMOKE="1")
    return env


def _check(result: subprocess.CompletedProcess[str], what: str) -> None:
    assert result.returncode == 0, f"{what} failed:\n{result.stdout[-4000:]}\n{result.stderr[-4000:]}"


def _runs_here(block: Block) -> bool:
    return not block.skip and not block.run_by


def _items() -> list[str]:
    """One test item per page for its Python blocks (one namespace, in order) and one per shell
    block (each on its own), so that pytest-xdist can spread a long page's parts."""
    items = []
    for page in DOC_FILES:
        blocks = [b for b in collect(page) if _runs_here(b)]
        items += [page] if any(b.is_python for b in blocks) else []
        items += [b.name for b in blocks if not b.is_python]
    return items


@pytest.mark.parametrize("item", _items())
def test_blocks_run_as_written(item: str, sandbox: Path) -> None:
    wall, cpu = time.perf_counter(), _children_cpu()
    page, _, line = item.partition(":")
    blocks = [b for b in collect(page) if _runs_here(b) and (b.name == item if line else b.is_python)]
    if not line:
        python = [{"name": b.name, "setup": b.setup, "code": b.code} for b in blocks]
        listing = sandbox / f".docs_test_{page.replace('/', '_')}.json"
        listing.write_text(json.dumps(python))
        result = subprocess.run([str(sandbox / ".venv" / "bin" / "python"), ".docs_test.py",
                                 str(listing)], cwd=sandbox, env=_env(sandbox),
                                capture_output=True, text=True, timeout=900)
        _check(result, f"the Python blocks of {page}")
    for block in (b for b in blocks if not b.is_python):
        result = subprocess.run(["bash", "-e", "-c", f"{block.setup}\n{block.code}"], cwd=sandbox,
                                env=_env(sandbox), capture_output=True, text=True, timeout=900)
        _check(result, block.name)
    print(f"\ndocs test: {item}: {len(blocks)} blocks in {time.perf_counter() - wall:.0f} s wall, "
          f"{_children_cpu() - cpu:.0f} s CPU")


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def test_every_block_left_out_says_why() -> None:
    blocks = all_blocks()
    left_out = [b for b in blocks if b.skip]
    report = "\n".join(f"  {b.name} ({b.lang}): {b.skip}" for b in left_out)
    print(f"\ndocs test: {len(blocks) - len(left_out)} of {len(blocks)} blocks run; left out:\n{report}")
    assert all(b.skip.strip() for b in left_out)
    assert len(left_out) <= 3, report  # 69 of 72 run now: a block left out is one more to explain


def test_blocks_run_by_another_test_are_read_by_it() -> None:
    """A ``run-by`` block is run by the named test, which reads it through ``run_by(__file__)``."""
    named = [b for b in all_blocks() if b.run_by]
    assert named
    for block in named:
        test_file = REPO / block.run_by
        assert test_file.is_file() and test_file.name.startswith("test_"), block.name
        assert "run_by(__file__)" in test_file.read_text(), f"{block.run_by} does not read {block.name}"


def test_markers_are_read() -> None:
    blocks = {b.name: b for b in collect("README.md")}
    first = blocks["README.md:4"]
    assert first.skip and "recursive" in first.skip and first.lang == "bash"
    assert isinstance(Block("x.md", 1, "python", "").name, str)
