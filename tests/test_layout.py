"""The package's structure: no import circle between its modules (module-level or inside
functions), no private name of one module imported by another, no oversized core file."""

import ast
import importlib.util
from pathlib import Path

import trigint

PACKAGE = Path(trigint.__file__).parent
CORE = PACKAGE.parents[1] / "crates"


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules() -> dict[str, Path]:
    return {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def resolve(current: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module named by a relative `from ... import`."""
    base = current.split(".") if is_package else current.split(".")[:-1]
    if node.level > 1:
        base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def is_module(name: str, known: dict) -> bool:
    """Whether `name` is a module of the package (a source file, or the compiled core)."""
    if name in known:
        return True
    try:
        return importlib.util.find_spec(name) is not None
    except ModuleNotFoundError:  # its parent is a module, not a package
        return False


def imports(name: str, path: Path, known: dict) -> list[tuple[str, str | None]]:
    """(module, imported name or None) for every import of a trigint module in `path`."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(a.name, None) for a in node.names if a.name.startswith("trigint")]
        elif isinstance(node, ast.ImportFrom):
            target = resolve(name, path.name == "__init__.py", node) if node.level else (node.module or "")
            if not target.startswith("trigint"):
                continue
            for a in node.names:
                sub = f"{target}.{a.name}"
                # `from . import x` imports the module x (compiled ones too), not a name
                out.append((sub, None) if is_module(sub, known) else (target, a.name))
    return out


def graph() -> dict[str, set[str]]:
    known = modules()
    edges = {m: set() for m in known}
    for name, path in known.items():
        for target, _ in imports(name, path, known):
            # importing a.b.c runs the package a.b's __init__ too (the root package excepted)
            parts = target.split(".")
            for k in range(2, len(parts) + 1):
                t = ".".join(parts[:k])
                if t in known and t != name:
                    edges[name].add(t)
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Every strongly connected component with more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in edges:
        if v not in index:
            visit(v)
    return found


def test_the_checker_finds_a_circle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_circle_between_modules():
    # A module's own package __init__ re-exporting it is not a circle of code: the package
    # imports its submodules, submodules import siblings, never the package's namespace back.
    edges = graph()
    for m in edges:
        edges[m] = {t for t in edges[m] if not m.startswith(t + ".")}
    assert cycles(edges) == []


def test_no_private_name_imported_from_another_module():
    known = modules()
    private = [
        f"{name} imports {target}.{attr}"
        for name, path in known.items()
        for target, attr in imports(name, path, known)
        if attr is not None and attr.startswith("_") and not attr.startswith("__")
    ]
    assert private == []


def private_members_used(source: str) -> list[str]:
    """`x._name` where x is not self, cls or a module the file imports: a private member of
    another object, used from outside its class."""
    tree = ast.parse(source)
    modules_bound = {"self", "cls"}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules_bound |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            modules_bound |= {a.asname or a.name for a in node.names}
    return [f"line {node.lineno}: {node.value.id}.{node.attr}" for node in ast.walk(tree)
            if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
            and isinstance(node.value, ast.Name) and node.value.id not in modules_bound]


def test_the_private_member_check_finds_one():
    assert private_members_used("import os\nx = other._secret + self._mine + os._exit\n") == [
        "line 2: other._secret"]


def test_no_private_member_of_another_object_is_used():
    found = {name: hits for name, path in modules().items()
             if (hits := private_members_used(Path(path).read_text(encoding="utf-8")))}
    assert found == {}


def test_no_core_source_file_over_600_lines():
    sizes = {p.relative_to(CORE).as_posix(): len(p.read_text(encoding="utf-8").splitlines())
             for p in CORE.rglob("*.rs")}
    assert sizes, "the core's sources were not found"
    assert {p: n for p, n in sizes.items() if n > 600} == {}


def test_figure_kinds_are_registered_once_and_resolve():
    """Each kind of figure: its spec keys in the schema and one row of trigint._figure_kinds
    whose run, claims and plot functions import."""
    from trigint._figure_kinds import KINDS, function
    from trigint.experiments import schema

    assert set(KINDS) == set(schema.KEYS) == set(schema.REQUIRED)
    for kind in KINDS:
        for role in ("run", "claims", "plot"):
            assert callable(function(kind, role)), (kind, role)
    import pytest

    with pytest.raises(ValueError, match="figure kind 'nope' is not one of families"):
        function("nope", "run")


def test_no_string_switch_on_the_kind_of_step():
    """The problem's stepper object (trigint._steppers) decides how steps are taken: no module
    branches on ``path == "krylov"`` or the layout's path."""
    import re
    from pathlib import Path

    package = Path(__file__).resolve().parents[1] / "python" / "trigint"
    switch = re.compile(r"""(\.path|get\("path"\)|\["path"\])\s*[!=]=\s*["']""")
    found = [f"{f.name}:{i}" for f in package.rglob("*.py")
             for i, line in enumerate(f.read_text(encoding="utf-8").splitlines(), 1) if switch.search(line)]
    assert found == []
