"""The module's surface: version, the shipped stub lists every public name, and the docstrings
say what the C++ headers say."""
import ast
import pathlib

import shadowsense as ss


def test_version():
    assert ss.__version__ == "0.1.0"
    assert ss.event_schema_version == 4


def test_the_stub_lists_every_public_name():
    stub = pathlib.Path(ss.__file__).with_name("__init__.pyi")
    tree = ast.parse(stub.read_text())
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            declared.add(node.target.id)
    public = {n for n in dir(ss._shadowsense) if not n.startswith("_")} | {"__version__"}
    assert public - declared == set()
    assert (pathlib.Path(ss.__file__).with_name("py.typed")).exists()


def test_docstrings_follow_the_headers():
    assert "one instance per thread" in ss.TouchPipeline.__doc__
    assert "hysteresis" in ss.TouchPipeline.__doc__ or "pending lift" in ss.TouchPipeline.__doc__
    assert "GIL is released" in ss.Runtime.__doc__
    assert "classify_every" in ss.Runtime.__doc__
    assert "CalibrationFileError" in ss.load_calibration.__doc__
