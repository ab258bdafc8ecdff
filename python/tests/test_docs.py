"""Every call has a docstring, and the type stubs (mca/__init__.pyi) list exactly what the module has."""
import ast
import inspect
import pathlib
import re

import mca


def public(obj):
    return [n for n in dir(obj) if not n.startswith("_")]


def stub_tree():
    path = pathlib.Path(mca.__file__).with_name("__init__.pyi")
    return ast.parse(path.read_text())


def described(obj):
    """Whether obj's docstring says something beyond pybind11's signature lines ("name(self: ...) -> T")."""
    lines = [line for line in (obj.__doc__ or "").splitlines()
             if line.strip() and not re.match(r"^(\d+\. )?\w+\(.*\)( -> .*)?$", line.strip())
             and line.strip() != "Overloaded function."]
    return bool(lines)


def test_every_call_and_key_has_a_docstring():
    missing = []
    stubbed = {n.name: {m.name for m in n.body if isinstance(m, ast.FunctionDef)}
               for n in stub_tree().body if isinstance(n, ast.ClassDef)}
    for name in mca.__all__:
        obj = getattr(mca, name)
        if not described(obj):
            missing.append(name)
        if inspect.isclass(obj) and name != "Error":
            # Its public members, and the special methods its stub lists (copy, pickle, comparison)
            members = set(public(obj)) | {m for m in stubbed.get(name, ()) if m.startswith("__") and m != "__init__"}
            for member in sorted(members):
                if not described(getattr(obj, member)):
                    missing.append(f"{name}.{member}")
    assert not missing, f"no docstring: {missing}"


def test_stubs_list_what_the_module_has():
    tree = stub_tree()
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef)}
    functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
    assert set(classes) | functions == set(mca.__all__)
    for name, node in classes.items():
        stubbed = {n.name for n in node.body if isinstance(n, ast.FunctionDef) and not n.name.startswith("_")}
        stubbed |= {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
        actual = set(public(getattr(mca, name)))
        if name == "Error":
            actual = set()  # BaseException's args and with_traceback
        assert stubbed == actual, f"{name}: stub only {stubbed - actual}, module only {actual - stubbed}"


def test_signatures_name_the_types_the_stubs_give():
    """help() shows each argument's type as the stubs give it (str, int, a path), never pybind11's `handle`
    for the arguments the module converts itself."""
    signatures = []
    for name in mca.__all__:
        obj = getattr(mca, name)
        calls = [obj] if not inspect.isclass(obj) else [getattr(obj, m) for m in public(obj) + ["__init__"]]
        signatures += [line for c in calls for line in (c.__doc__ or "").splitlines() if "(" in line and "->" in line]
    assert signatures
    shown = [s for s in signatures if "handle" in s]
    assert not shown, "\n".join(shown)
    joined = "\n".join(signatures)
    for want in ("load(path: Union[str, os.PathLike])", "advance(self: mca._mca.Simulation, steps: int, progress: "
                 "Optional[Callable[[int, int], Any]] = None)", "scene: Union[Scene, str, os.PathLike], threads: int = 0, "
                 "backend: Optional[str] = None", "size: Tuple[int, int] = (1280, 720)"):
        assert want in joined
