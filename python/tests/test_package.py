"""The installed package as a user meets it: its API only, with type information."""

import ast
import pathlib

import ghm
from ghm import _ghm


def test_dir_shows_the_api_only():
    names = dir(ghm)
    assert names == sorted(ghm.__all__)
    for imported in ("np", "os", "Any", "Optional", "gymnasium", "spaces"):
        assert imported not in names
    for name in ghm.__all__:
        assert hasattr(ghm, name), name


def test_the_wheel_ships_type_information_that_matches_the_compiled_module():
    folder = pathlib.Path(ghm.__file__).parent
    assert (folder / "py.typed").is_file()
    stub = ast.parse((folder / "_ghm.pyi").read_text())
    stubbed = {
        node.name
        for node in stub.body
        if isinstance(node, (ast.ClassDef, ast.FunctionDef))
    }
    compiled = {name for name in dir(_ghm) if not name.startswith("_")}
    assert stubbed == compiled
    # Each compiled class's public methods and properties are in its stub.
    for node in stub.body:
        if isinstance(node, ast.ClassDef) and not node.name.endswith("Error"):
            declared = {f.name for f in node.body if isinstance(f, ast.FunctionDef)}
            public = {n for n in dir(getattr(_ghm, node.name)) if not n.startswith("_")}
            assert public == declared - {"__init__"}, node.name
