"""The structure of the library, read from the source (no import is run): the generic packages
never import the bridge 705 case study, no file of ``torchshm/`` or ``benchmarks/`` imports
itself back through others (a circle; lazy imports inside functions and ``TYPE_CHECKING`` ones
included), and no library file is over 300 lines."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: the most lines of one library module
MAX_LINES = 300
#: the rows of docs/architecture.md ("Layers"), bottom = 0: a package imports its row or below
ROWS = {"data": 0, "arrays": 0, "_lazy": 0, "forward": 1, "kernels": 1, "priors": 1, "likelihood": 2,
        "storage": 2, "config": 2, "problem": 3, "surrogate": 3, "inference": 4, "predictive": 5,
        "casestudy": 6, "cli": 7, "__init__": 7}
#: the one import that runs up a row (a command that serves a surrogate file), and why
UPWARD = {("torchshm/forward/umbridge_server.py", "torchshm/surrogate/__init__.py")}
#: packages of torchshm that sit above the library and may import the case study
APPLICATIONS = ("casestudy", "cli")


def _module_file(name: str) -> Path | None:
    """The file of dotted module ``name`` under ROOT, or None (a third-party module)."""
    base = ROOT.joinpath(*name.split("."))
    for path in (base.with_suffix(".py"), base / "__init__.py"):
        if path.is_file():
            return path
    return None


def _imports(path: Path) -> set[Path]:
    """Files of this repository that ``path`` names in any import statement."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts)
    if path.name != "__init__.py":
        package = package.rpartition(".")[0]
    found: set[Path | None] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(_module_file(alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            for alias in node.names:  # ``from a import b``: the submodule b if it is one, else a
                found.add(_module_file(f"{base}.{alias.name}") or _module_file(base))
    return {target for target in found if target is not None and target != path}


def _graph(*folders: str) -> dict[Path, set[Path]]:
    files = [p for folder in folders for p in sorted((ROOT / folder).rglob("*.py"))]
    return {p: _imports(p) for p in files}


def _circles(graph: dict[Path, set[Path]]) -> list[list[str]]:
    """Strongly connected components of more than one file (Tarjan), as relative paths."""
    index: dict[Path, int] = {}
    low: dict[Path, int] = {}
    stack: list[Path] = []
    on_stack: set[Path] = set()
    out: list[list[str]] = []

    def visit(node: Path) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in graph.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(str(top.relative_to(ROOT)))
                if top == node:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for node in graph:
        if node not in index:
            visit(node)
    return out


def test_no_file_imports_itself_back() -> None:
    assert _circles(_graph("torchshm", "benchmarks")) == []


def test_generic_packages_never_import_the_case_study() -> None:
    case = ROOT / "torchshm" / "casestudy"
    wrong = []
    for path, targets in _graph("torchshm").items():
        parts = path.relative_to(ROOT / "torchshm").parts
        if parts[0] in APPLICATIONS or parts == ("__init__.py",):
            continue
        wrong += [f"{path.relative_to(ROOT)} -> {t.relative_to(ROOT)}" for t in targets if case in t.parents]
    assert wrong == []


def test_the_reading_sees_imports() -> None:
    """The reader itself finds known edges (a module-level import and a submodule import)."""
    graph = _graph("torchshm")
    model = ROOT / "torchshm" / "casestudy" / "model.py"
    assert ROOT / "torchshm" / "casestudy" / "priors.py" in graph[model]
    assert ROOT / "torchshm" / "storage" / "evaluate.py" in graph[ROOT / "torchshm" / "storage" / "parallel.py"]


def test_no_library_file_over_300_lines() -> None:
    long = {str(p.relative_to(ROOT)): n for p in sorted((ROOT / "torchshm").rglob("*.py"))
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert long == {}


def _package(path: Path) -> str:
    parts = path.relative_to(ROOT / "torchshm").parts
    return "__init__" if parts == ("__init__.py",) else parts[0].removesuffix(".py")


def test_packages_import_only_their_row_or_below() -> None:
    upward = {(str(path.relative_to(ROOT)), str(t.relative_to(ROOT)))
              for path, targets in _graph("torchshm").items() for t in targets
              if ROWS[_package(t)] > ROWS[_package(path)]}
    assert upward == UPWARD
