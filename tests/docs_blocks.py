"""The fenced code blocks of the documentation, as :mod:`tests.test_docs` runs them.

A block is run as a reader would: the Python blocks of one file in order, in one namespace; a
shell block with ``bash -e``. An HTML comment on the line before a block's fence (invisible on a
rendered page, visible to whoever edits the block) can say how:

``<!-- docs-test: skip: <why> -->``
    the block is not run (counted and listed with its reason);
``<!-- docs-test: setup`` ... ``-->``
    the lines between are run just before the block (Python or shell, as the block): what the
    page leaves to the reader, e.g. a measurement file of their own;
``<!-- docs-test: run-by: tests/<dir>/test_<name>.py -->``
    the block is run by that test, which reads it here (``run_by(__file__)``) and checks what it
    writes (with a small budget appended to its commands); the docs test does not run it again
    and checks that the named test reads it.
"""

from __future__ import annotations

import re
import shlex
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
#: the pages whose blocks are run
DOC_FILES = ["README.md", *sorted(str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md")),
             "conf/README.md",
             *sorted(str(p.relative_to(REPO)) for p in (REPO / "examples").glob("*/README.md"))]
PYTHON = ("python",)
SHELL = ("bash", "sh", "shell", "console")
_FENCE = re.compile(r"^(\s*)```(\w*)")
_MARKER = re.compile(r"<!--\s*docs-test:\s*(skip|setup|run-by)\s*:?\s*(.*?)\s*-->\s*$", re.S)


@dataclass
class Block:
    """One fenced block of a page: ``path`` (from the repository root), ``line`` (1-based, of
    the opening fence), ``lang`` (python or a shell), ``code``, and its marker's ``setup`` and
    ``skip`` (the reason), or the test that runs it (``run_by``), if any."""

    path: str
    line: int
    lang: str
    code: str
    setup: str = ""
    skip: str | None = None
    run_by: str | None = None

    @property
    def name(self) -> str:
        return f"{self.path}:{self.line}"

    @property
    def is_python(self) -> bool:
        return self.lang in PYTHON


def collect(path: str) -> list[Block]:
    """The Python and shell blocks of the page ``path``, in order."""
    lines = (REPO / path).read_text(encoding="utf-8").splitlines()
    blocks, i = [], 0
    while i < len(lines):
        fence = _FENCE.match(lines[i])
        if not fence:
            i += 1
            continue
        indent, lang = fence.groups()
        end = next(j for j in range(i + 1, len(lines)) if lines[j].strip() == "```")
        if lang in PYTHON + SHELL:
            code = "\n".join(line[len(indent):] for line in lines[i + 1:end])
            block = Block(path, i + 1, lang, code)
            _read_marker(block, lines[:i])
            blocks.append(block)
        i = end + 1
    return blocks


def _read_marker(block: Block, before: list[str]) -> None:
    """Fill ``block.skip`` / ``block.setup`` from an HTML comment ending on the line before."""
    if not before or not before[-1].rstrip().endswith("-->"):
        return
    start = max(k for k, line in enumerate(before) if "<!--" in line)
    marker = _MARKER.search("\n".join(before[start:]))
    if marker is None:
        return
    kind, text = marker.groups()
    if kind == "skip":
        block.skip = " ".join(text.split())
    elif kind == "run-by":
        block.run_by = text.strip()
    else:
        block.setup = text


def all_blocks() -> list[Block]:
    """Every Python and shell block of :data:`DOC_FILES`."""
    return [b for path in DOC_FILES for b in collect(path)]


def run_by(test_file: str | Path) -> list[Block]:
    """The blocks whose marker names ``test_file`` (a test module's ``__file__``) as their runner."""
    name = Path(test_file).resolve().relative_to(REPO).as_posix()
    return [b for b in all_blocks() if b.run_by == name]


def commands(block: Block) -> list[list[str]]:
    """The commands of a shell block, one per line (``\\`` continues a line), split as the shell
    does."""
    text = block.code.replace("\\\n", " ")
    return [shlex.split(line) for line in text.splitlines() if line.strip()]
