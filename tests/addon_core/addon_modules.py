# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's modules and their imports, read with ``ast`` (nothing of the add-on runs)."""

import ast
import importlib
import os
import sys
import types

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ADDON = os.path.join(REPO, "addon", "sweep_deform")
PACKAGE = "sweep_deform"


def module_files():
    """{dotted module name: file path} of every .py file of the add-on ("sweep_deform.core.native")."""
    found = {}
    for folder, dirs, files in os.walk(ADDON):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        rel = os.path.relpath(folder, ADDON)
        parts = [PACKAGE] + ([] if rel == "." else rel.split(os.sep))
        for f in sorted(files):
            if f.endswith(".py"):
                name = parts if f == "__init__.py" else parts + [f[:-3]]
                found[".".join(name)] = os.path.join(folder, f)
    return found


def import_core(name):
    """The module core/<name> in plain Python. The add-on's __init__.py (which registers with
    Blender) is not run: the package is an empty module on the add-on's folder."""
    if PACKAGE not in sys.modules:
        package = types.ModuleType(PACKAGE)
        package.__path__ = [ADDON]
        sys.modules[PACKAGE] = package
    return importlib.import_module(f"{PACKAGE}.core.{name}")


def _is_package(name, files):
    return files[name].endswith("__init__.py")


def imports(name, files):
    """[(imported module, line, inside a function or class)] of one add-on module: absolute
    imports as written, relative ones resolved to the add-on's dotted module names (a name
    taken from a package counts as that submodule when there is one)."""
    tree = ast.parse(open(files[name]).read(), files[name])
    package = name if _is_package(name, files) else name.rpartition(".")[0]
    out = []

    def visit(node, nested):
        for child in ast.iter_child_nodes(node):
            inner = nested or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef, ast.Lambda))
            if isinstance(child, ast.Import):
                out.extend((a.name, child.lineno, nested) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")
                    base = base[:len(base) - (child.level - 1)]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module
                out.append((target, child.lineno, nested))
                for a in child.names:
                    sub = f"{target}.{a.name}"
                    if sub in files:
                        out.append((sub, child.lineno, nested))
            visit(child, inner)

    visit(tree, False)
    return out


def graph():
    """{module: set of add-on modules it imports} (imports of outside modules left out)."""
    files = module_files()
    return {name: {m for m, _, _ in imports(name, files) if m in files and m != name} for name in files}


def cycles(edges):
    """The import circles of `edges` (strongly connected components of more than one module,
    or a module importing itself), each a sorted list (Tarjan's algorithm)."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    counter = [0]

    def strongconnect(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in edges.get(v, ()):
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            strongconnect(v)
    return found
