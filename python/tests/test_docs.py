"""Python help (issue 27): every public function and class of ``djkr`` carries its full
docstring at runtime (``help()``, Jupyter's ``?``), written once as the Rust doc comments of
``python/src/lib.rs``, and the type stub ``djkr/__init__.pyi`` holds the same docstrings.

The stub's docstrings are generated from the runtime ones: after changing a doc comment, run

    python python/tests/test_docs.py --write

with the rebuilt package installed (``cargo test --release --test cli python::`` installs it into
target/tmp/python-venv), and commit the stub it rewrites.
"""

import ast
import inspect
import io
import pydoc
import sys
from pathlib import Path

import djkr

STUB = Path(djkr.__file__).resolve().parent / "__init__.pyi"
# The stub in the source tree (the installed package's copy is the same file, installed).
SOURCE_STUB = Path(__file__).resolve().parents[1] / "djkr" / "__init__.pyi"
# Every public name: a function added to the binding is held to the same rules.
FUNCTIONS = [n for n in djkr.__all__ if not inspect.isclass(getattr(djkr, n))]
CLASSES = [n for n in djkr.__all__ if inspect.isclass(getattr(djkr, n))]


def runtime_doc(path):
    """The runtime docstring of a dotted name under djkr ("" for the module itself)."""
    obj = djkr
    for part in filter(None, path.split(".")):
        obj = inspect.getattr_static(obj, part) if inspect.isclass(obj) else getattr(obj, part)
    doc = obj.__doc__
    return inspect.cleandoc(doc) if doc else None


def stub_docstrings(text):
    """(dotted name, docstring node) of every docstring in the stub: the module's, each class's
    and function's, and each attribute's (the string after an annotated attribute)."""
    tree = ast.parse(text)
    found = []

    def walk(body, prefix, top):
        if top is not None and body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                and isinstance(body[0].value.value, str):
            found.append((top, body[0].value))
        for i, node in enumerate(body):
            if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
                walk(node.body, f"{prefix}{node.name}.", f"{prefix}{node.name}")
            elif isinstance(node, ast.AnnAssign) and prefix and i + 1 < len(body):
                nxt = body[i + 1]
                if isinstance(nxt, ast.Expr) and isinstance(nxt.value, ast.Constant) and isinstance(nxt.value.value, str):
                    found.append((f"{prefix}{node.target.id}", nxt.value))

    walk(tree.body, "", "")
    return found


def quoted(doc, indent):
    """A docstring as the stub writes it, at `indent` (the first line after the quotes)."""
    lines = doc.split("\n")
    if len(lines) == 1:
        return f'"""{doc}"""'
    pad = " " * indent
    body = "\n".join((pad + line) if line else "" for line in lines[1:])
    return f'"""{lines[0]}\n{body}\n{pad}"""'


def synced(text):
    """The stub `text` with every docstring replaced by the runtime one."""
    lines = text.split("\n")
    nodes = sorted(stub_docstrings(text), key=lambda x: -x[1].lineno)
    for name, node in nodes:
        doc = runtime_doc(name)
        assert doc is not None, f"djkr.{name} has a docstring in the stub but none at runtime"
        assert '"""' not in doc and "\\" not in doc, f"djkr.{name}: the generator does not escape"
        first, last = node.lineno - 1, node.end_lineno - 1
        head = lines[first][: node.col_offset]
        tail = lines[last][node.end_col_offset:]
        new = (head + quoted(doc, node.col_offset) + tail).split("\n")
        lines[first: last + 1] = new
    return "\n".join(lines)


def test_stub_docstrings_equal_the_runtime_ones():
    text = SOURCE_STUB.read_text()
    assert synced(text) == text, (
        "python/djkr/__init__.pyi's docstrings differ from the runtime ones (the doc comments of "
        "python/src/lib.rs): run `python python/tests/test_docs.py --write` and commit the stub"
    )
    documented = {name for name, _ in stub_docstrings(text)}
    for name in FUNCTIONS + CLASSES + [""]:
        assert name in documented, f"djkr.{name}: no docstring in the stub"


def test_every_public_name_is_in_the_stub_with_the_same_parameters():
    tree = ast.parse(SOURCE_STUB.read_text())
    stubs = {n.name: n for n in tree.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    assert set(FUNCTIONS) >= {"run", "cycle", "pulloff", "validate", "resonance", "sweep", "points"}
    assert set(CLASSES) == {"Run", "Fit", "ScenarioError", "ScenarioTypeError", "OutputFolderError", "Prediction",
                            "Design"}
    for name in FUNCTIONS:
        params = [a.arg for a in stubs[name].args.args]
        assert list(inspect.signature(getattr(djkr, name)).parameters) == params, name
    for name in CLASSES:
        assert name in stubs, name


def help_text(obj):
    out = io.StringIO()
    pydoc.Helper(output=out).help(obj)
    return out.getvalue()


def test_help_is_full():
    """Every public function's help has its parameters with units, what it returns and an
    example; help(djkr.sweep) is at least ten lines (issue 27)."""
    assert len(help_text(djkr.sweep).strip().splitlines()) >= 10
    for name in FUNCTIONS:
        f = getattr(djkr, name)
        doc = inspect.getdoc(f)
        text = help_text(f)
        assert str(inspect.signature(f)) in text.replace("\n", ""), name
        for section in ("Parameters\n----------", "Returns\n-------", "Examples\n--------"):
            assert section in doc, f"djkr.{name}: no {section.splitlines()[0]}"
        for p in inspect.signature(f).parameters:
            assert f"\n{p} : " in doc, f"djkr.{name}: parameter {p} undocumented"
        assert ">>> " in doc and "djkr." in doc
    for name in CLASSES:
        assert len(inspect.getdoc(getattr(djkr, name)).splitlines()) >= 2, name
    # Each time series says its unit.
    for name in ["t", "x_s", "v_s", "x_b", "x_k", "delta", "a", "a_dot", "F", "G", "w"]:
        doc = runtime_doc(f"Run.{name}")
        assert doc and "(" in doc and ")" in doc, name


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python python/tests/test_docs.py --write  (rewrite the stub's docstrings)")
    SOURCE_STUB.write_text(synced(SOURCE_STUB.read_text()))
    print(f"wrote {SOURCE_STUB}")
