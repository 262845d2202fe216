"""The layout's rules, read from the source with ``ast`` (every import, module- and function-level):

* no import cycles among walkmon's modules (drivers/ counted as walkmon.drivers, as installed);
* threads, sockets, SQLite and subprocesses only in the service packages (walkmon/live/, walkmon/serve/,
  walkmon/batching/), walkmon/commands/, walkmon/api.py and drivers/;
* argparse and printing only in walkmon/commands/;
* the rotation, imu and gait packages do no I/O: no file, socket, SQLite or subprocess use.

Imports under ``if TYPE_CHECKING:`` are annotations only (never executed) and are not edges.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

#: Modules that run threads or talk to sockets, SQLite or other processes.
CONCURRENCY_AND_IPC = {"threading", "_thread", "sqlite3", "socket", "subprocess", "multiprocessing", "asyncio",
                       "concurrent", "selectors", "socketserver"}
#: Where those may be imported (path prefixes relative to the repository): the service packages (the live monitor,
#: the dashboard's read-only store and HTTP server, Dask batch runs), the commands, the API and the drivers.
IPC_ALLOWED = ("walkmon/live/", "walkmon/serve/", "walkmon/batching/", "walkmon/commands/", "walkmon/api.py",
               "drivers/")
#: The hardware-free, I/O-free packages.
PURE = ("walkmon/rotation/", "walkmon/imu/", "walkmon/gait/")
#: Imports that mean I/O in a pure package.
IO_MODULES = CONCURRENCY_AND_IPC | {"shutil", "tempfile", "glob", "urllib", "http", "ftplib", "serial", "depthai",
                                    "h5py", "pyarrow", "yaml", "csv", "sys"}
#: Calls that mean I/O: builtins, and methods of Path / numpy / cv2 / json that touch files.
IO_CALLS = {"open", "print", "input"}
IO_METHODS = {"write_text", "write_bytes", "read_text", "read_bytes", "mkdir", "unlink", "rmdir", "touch",
              "rename", "replace_file", "savetxt", "loadtxt", "savez", "savez_compressed", "genfromtxt", "fromfile",
              "tofile", "imwrite", "imread", "VideoCapture", "VideoWriter", "dump"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(REPO).with_suffix("")
    parts = list(rel.parts)
    if parts[0] == "drivers":
        parts = ["walkmon", *parts]
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _sources() -> dict[str, Path]:
    files = sorted([*(REPO / "walkmon").rglob("*.py"), *(REPO / "drivers").rglob("*.py")])
    return {_module_name(p): p for p in files if "__pycache__" not in p.parts}


SOURCES = _sources()


@dataclass(frozen=True)
class _Import:
    module: str  # absolute dotted name as written (resolved for relative imports)
    names: tuple[str, ...]  # for "from X import a, b"
    line: int


def _type_checking_blocks(tree: ast.AST) -> set[int]:
    """ids of nodes inside ``if TYPE_CHECKING:`` bodies."""
    inside: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else test.attr if isinstance(test, ast.Attribute) else ""
            if name == "TYPE_CHECKING":
                for stmt in node.body:
                    inside.update(id(n) for n in ast.walk(stmt))
    return inside


def _imports(module: str, path: Path) -> Iterator[_Import]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    skip = _type_checking_blocks(tree)
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield _Import(alias.name, (), node.lineno)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            yield _Import(base, tuple(a.name for a in node.names), node.lineno)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module" and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                yield _Import(arg.value, (), node.lineno)
    if module == "walkmon":
        # the package's lazy public names (PEP 562 __getattr__): each module named in its table is imported on
        # first use of one of its names, so it is an edge like an import
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in SOURCES:
                yield _Import(node.value, (), getattr(node, "lineno", 0))


def _targets(imp: _Import) -> set[str]:
    """The walkmon modules an import executes (the most specific existing module of each name)."""
    out = set()
    candidates = [f"{imp.module}.{n}" for n in imp.names] or [imp.module]
    for name in candidates:
        while name and name not in SOURCES:
            name = name.rpartition(".")[0]
        if name:
            out.add(name)
    if not out and imp.module in SOURCES:
        out.add(imp.module)
    return out


def _graph() -> dict[str, set[str]]:
    return {m: {t for imp in _imports(m, p) for t in _targets(imp) if t != m} for m, p in SOURCES.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _rel(path: Path) -> str:
    return path.relative_to(REPO).as_posix()


def test_the_checker_sees_the_imports_it_must() -> None:
    """The parser finds function-level and relative imports, and skips TYPE_CHECKING ones (so an empty result
    below means something)."""
    graph = _graph()
    assert len(SOURCES) > 50
    assert "walkmon._version" in graph["walkmon"]  # module level
    assert "walkmon.api" in graph["walkmon"]  # a lazy public name (walkmon.analyze)
    assert "walkmon.live.session_log" in graph["walkmon.api"]  # function level, inside a method
    assert "walkmon.drivers.video_file" in graph["walkmon.api"]  # drivers/ is walkmon.drivers
    assert "walkmon.drivers.imu_types" not in graph["walkmon.live.pipeline"]  # TYPE_CHECKING only
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycles() -> None:
    cycles = _cycles(_graph())
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def _imported_roots(path: Path) -> Iterator[tuple[str, int]]:
    for imp in _imports(_module_name(path), path):
        yield imp.module.split(".")[0], imp.line


@pytest.mark.parametrize("module", sorted(SOURCES))
def test_threads_sockets_sqlite_and_subprocesses_only_where_allowed(module: str) -> None:
    path = SOURCES[module]
    if _rel(path).startswith(IPC_ALLOWED):
        return
    bad = [f"{root} (line {line})" for root, line in _imported_roots(path) if root in CONCURRENCY_AND_IPC]
    assert not bad, f"{_rel(path)} imports {', '.join(bad)}: only {', '.join(IPC_ALLOWED)} may"


@pytest.mark.parametrize("module", sorted(SOURCES))
def test_argparse_only_in_commands(module: str) -> None:
    path = SOURCES[module]
    if _rel(path).startswith("walkmon/commands/"):
        return
    bad = [line for root, line in _imported_roots(path) if root == "argparse"]
    assert not bad, f"{_rel(path)} imports argparse (line {bad[0]}): command-line parsing is walkmon/commands/'s"


def _io_uses(path: Path) -> Iterator[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _type_checking_blocks(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import | ast.ImportFrom):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            for name in names:
                if name.split(".")[0] in IO_MODULES:
                    yield f"import {name} (line {node.lineno})"
        elif isinstance(node, ast.Call):
            f = node.func
            if isinstance(f, ast.Name) and f.id in IO_CALLS:
                yield f"{f.id}() (line {node.lineno})"
            elif isinstance(f, ast.Attribute) and f.attr in IO_METHODS | {"open"}:
                yield f".{f.attr}() (line {node.lineno})"


@pytest.mark.parametrize("module", sorted(m for m, p in SOURCES.items() if _rel(p).startswith(PURE)))
def test_rotation_imu_and_gait_do_no_io(module: str) -> None:
    uses = list(_io_uses(SOURCES[module]))
    assert not uses, f"{_rel(SOURCES[module])} does I/O: {', '.join(uses)} (move it to walkmon/api.py or commands)"


def test_the_io_check_catches_io(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text("import sqlite3\nfrom pathlib import Path\n\ndef f(p):\n    Path(p).write_text('x')\n"
                   "    with open(p) as fh:\n        print(fh.read())\n", encoding="utf-8")
    uses = " ".join(_io_uses(src))
    for what in ("import sqlite3", ".write_text()", "open()", "print()"):
        assert what in uses, what
