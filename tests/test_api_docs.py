"""The public API is documented: every module declares ``__all__``, and every public function,
class and method carries a numpydoc docstring with the sections its signature calls for.

ruff's pydocstyle rules (numpy convention) check the form of the docstrings; this checks their
content: Parameters for a callable that takes any, Returns (or Yields) for one that gives a
value, and an Examples section with a doctest (run by ``--doctest-modules``) for each public
function and class.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import lanefinder

MODULES = sorted(m.name for m in pkgutil.iter_modules(lanefinder.__path__) if m.name != "__main__")


def _public_members(mod):
    for name in mod.__all__:
        obj = getattr(mod, name)
        if (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == mod.__name__:
            yield name, obj


def _params(fn) -> list[str]:
    try:
        sig = inspect.signature(fn)
    except (TypeError, ValueError):
        return []
    return [p for p in sig.parameters if p not in ("self", "cls") and not p.startswith("_")]


def _returns_value(fn) -> bool:
    ann = inspect.signature(fn).return_annotation
    return ann not in (inspect.Signature.empty, None, "None")


def _problems(qualname: str, fn, need_example: bool) -> list[str]:
    doc = inspect.getdoc(fn) or ""
    out = []
    if not doc:
        return [f"{qualname}: no docstring"]
    if _params(fn) and "Parameters\n----------" not in doc:
        out.append(f"{qualname}: no Parameters section")
    if _returns_value(fn) and "Returns\n-------" not in doc and "Yields\n------" not in doc:
        out.append(f"{qualname}: no Returns section")
    if need_example and ("Examples\n--------" not in doc or ">>>" not in doc):
        out.append(f"{qualname}: no Examples section with a doctest")
    return out


@pytest.mark.parametrize("name", MODULES)
def test_module_declares_all_and_documents_its_public_api(name):
    mod = importlib.import_module(f"lanefinder.{name}")
    assert (mod.__doc__ or "").strip(), f"lanefinder.{name} has no module docstring"
    assert hasattr(mod, "__all__"), f"lanefinder.{name} has no __all__"
    for public in mod.__all__:
        assert hasattr(mod, public), f"lanefinder.{name}.__all__ names {public}, which is not there"
    problems = []
    for qual, obj in _public_members(mod):
        if inspect.isfunction(obj):
            problems += _problems(f"{name}.{qual}", obj, need_example=True)
            continue
        doc = inspect.getdoc(obj) or ""
        if not doc:
            problems.append(f"{name}.{qual}: no docstring")
        elif "Examples\n--------" not in doc or ">>>" not in doc:
            problems.append(f"{name}.{qual}: no Examples section with a doctest")
        fields = getattr(obj, "__dataclass_fields__", None) or getattr(obj, "model_fields", None)
        if fields and "Attributes\n----------" not in doc and "Parameters\n----------" not in doc:
            problems.append(f"{name}.{qual}: fields but no Attributes or Parameters section")
        for mname, member in vars(obj).items():
            if mname.startswith("_"):
                continue
            fn = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
            if inspect.isfunction(fn):
                problems += _problems(f"{name}.{qual}.{mname}", fn, need_example=False)
    assert not problems, "\n".join(problems)


def test_the_package_exports_the_main_api():
    for name in ("Config", "LaneFinder", "LaneResult", "Line", "LaneFinderError", "load_config"):
        assert name in lanefinder.__all__, name
