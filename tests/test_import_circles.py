"""No two modules of the package import each other, directly or through an import inside a function.

import-linter's layer contract keeps the packages pointing down; this check covers the modules inside one
package, where a circle is hidden by moving one of the two imports into a function body.
"""

import ast
from pathlib import Path

import simgap

PACKAGE_ROOT = Path(simgap.__file__).parent


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE_ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imported_modules(path: Path, module: str, known: set[str]) -> set[str]:
    """The package's modules that `path` imports anywhere in its body (a `from m import name` counts as
    importing `m.name` when that is a module, else `m`)."""
    is_package = path.name == "__init__.py"
    imported: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            imported.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                submodule = f"{source}.{alias.name}"
                imported.add(submodule if submodule in known else source)
    return {name for name in imported if name in known and name != module}


def _import_graph() -> dict[str, set[str]]:
    paths = {_module_name(path): path for path in PACKAGE_ROOT.rglob("*.py")}
    known = set(paths)
    return {module: _imported_modules(path, module, known) for module, path in paths.items()}


def _mutual_pairs(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """Pairs of modules each importing the other; a package's `__init__` re-exporting its own modules is no
    circle of two modules, so a package and the modules inside it are left out."""
    pairs = []
    for module, imported in graph.items():
        for other in imported:
            inside = other.startswith(module + ".") or module.startswith(other + ".")
            if module < other and module in graph.get(other, set()) and not inside:
                pairs.append((module, other))
    return sorted(pairs)


def test_the_graph_sees_function_local_imports(tmp_path):
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "a.py").write_text("from pkg.b import g\n")
    (package / "b.py").write_text("def g():\n    from .a import f\n    return f\n")
    known = {"pkg", "pkg.a", "pkg.b"}
    graph = {name: _imported_modules(package / f"{name.split('.')[-1]}.py", name, known) for name in ("pkg.a", "pkg.b")}
    assert _mutual_pairs(graph) == [("pkg.a", "pkg.b")]


def test_no_two_modules_import_each_other():
    assert _mutual_pairs(_import_graph()) == []
