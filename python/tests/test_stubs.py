"""The .pyi stubs declare exactly the module's public API, so IDEs see what exists."""

import ast
import inspect
import pathlib

import fringe

PACKAGE = pathlib.Path(fringe.__file__).parent


def declared(stub):
    tree = ast.parse((PACKAGE / stub).read_text())
    names, members = set(), {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        if isinstance(node, ast.ClassDef):
            members[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)
                                  and not n.name.startswith("_")} | {
                n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
    return names, members


def public(obj):
    return {n for n in dir(obj) if not n.startswith("_")}


def test_top_level_stub_matches_module():
    names, members = declared("__init__.pyi")
    module_names = public(fringe._fringe) - {"evaluate"}
    assert module_names == names
    for cls, declared_members in members.items():
        actual = public(getattr(fringe, cls))
        if issubclass(getattr(fringe, cls), BaseException):
            continue
        # Enums carry pybind11's helpers; compare their values only.
        if hasattr(getattr(fringe, cls), "__members__"):
            actual = set(getattr(fringe, cls).__members__) | {"name", "value"}
        assert actual == declared_members, cls


def test_evaluate_stub_matches_submodule():
    names, _ = declared("evaluate.pyi")
    assert public(fringe.evaluate) == names
    import fringe.evaluate as ev  # the submodule is importable by name
    assert ev is fringe.evaluate


def test_every_function_has_a_docstring():
    for name in public(fringe._fringe):
        obj = getattr(fringe, name)
        if inspect.isbuiltin(obj) or inspect.isroutine(obj):
            assert obj.__doc__ and len(obj.__doc__.splitlines()) > 1, name
