"""The API reference as rendered: every name on docs/api.rst has a numpydoc docstring whose
Parameters match its signature, with no stray paragraph parsed as a parameter (a bold fake
name with backticks on the page), and whose Attributes each carry a description (no blank
rows). Classes built as dataclasses describe every field. Checked with numpydoc's own parser,
the one the documentation build uses."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import warnings
from pathlib import Path

import pytest
from numpydoc.docscrape import NumpyDocString

API = Path(__file__).resolve().parents[1] / "docs" / "api.rst"
NAME = re.compile(r"^\*{0,2}[A-Za-z_][A-Za-z0-9_]*$")


def api_names() -> list[str]:
    """The dotted names of every entry of the autosummary tables of docs/api.rst."""
    names, module, in_table = [], "trigint", False
    for line in API.read_text(encoding="utf-8").splitlines():
        if line.startswith(".. currentmodule::"):
            module = line.split("::")[1].strip()
        elif line.strip().startswith(".. autosummary::"):
            in_table = True
        elif in_table and line.startswith("   ") and line.strip() and not line.strip().startswith(":"):
            names.append(f"{module}.{line.strip()}")
        elif in_table and line.strip() and not line.startswith(" "):
            in_table = False
    return names


def resolve(dotted: str):
    """The object a dotted name documents (``trigint.integrate`` is the function, not the
    module of the same name)."""
    parts = dotted.split(".")
    obj, path = importlib.import_module(parts[0]), parts[0]
    for part in parts[1:]:
        path += "." + part
        obj = getattr(obj, part) if hasattr(obj, part) else importlib.import_module(path)
    return obj


def parse(obj, where: str) -> NumpyDocString:
    doc = inspect.getdoc(obj)
    assert doc, f"{where}: no docstring"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpydoc warns of unknown sections and malformed ones
        return NumpyDocString(doc)


def names_of(entries) -> list[str]:
    out = []
    for entry in entries:
        for name in entry.name.split(","):
            name = name.strip()
            assert NAME.match(name), f"{entry.name!r} is not a parameter name (a paragraph parsed as one?)"
            out.append(name.lstrip("*"))
    return out


def signature_names(func) -> list[str]:
    params = list(inspect.signature(func).parameters.values())
    return [p.name for p in params if p.name not in ("self", "cls")]


def public_methods(cls) -> list[tuple[str, object]]:
    out = []
    for name, member in vars(cls).items():
        if name.startswith("_"):
            continue
        if isinstance(member, staticmethod | classmethod):
            member = member.__func__
        if inspect.isfunction(member):
            out.append((name, member))
    return out


def check_callable(func, where: str) -> None:
    doc = parse(func, where)
    summary = " ".join(doc["Summary"]).strip()
    assert summary and not summary.endswith(":"), f"{where}: the summary line {summary!r} is incomplete"
    documented = names_of(doc["Parameters"]) + names_of(doc["Other Parameters"])
    expected = signature_names(func)
    assert sorted(documented) == sorted(expected), (
        f"{where}: Parameters document {documented}, the signature has {expected}")


def check_class(cls, where: str) -> None:
    doc = parse(cls, where)
    summary = " ".join(doc["Summary"]).strip()
    assert summary and not summary.endswith(":"), f"{where}: the summary line {summary!r} is incomplete"
    for entry in doc["Attributes"]:
        assert "".join(entry.desc).strip(), f"{where}: attribute {entry.name!r} has no description"
    attributes = names_of(doc["Attributes"])
    parameters = names_of(doc["Parameters"])
    if dataclasses.is_dataclass(cls):
        # a result type: what users read are its fields and properties
        wanted = [f.name for f in dataclasses.fields(cls) if not f.name.startswith("_")]
        wanted += [n for n, m in vars(cls).items() if isinstance(m, property) and not n.startswith("_")]
        missing = sorted(set(wanted) - set(attributes) - set(parameters))
        assert not missing, f"{where}: fields without a description: {missing}"
    else:
        init = cls.__init__
        # exceptions and plain classes that take the constructor of a built-in type
        inherited = not any("__init__" in vars(c) for c in cls.__mro__ if c.__module__ != "builtins")
        expected = [] if init is object.__init__ or inherited else signature_names(init)
        assert sorted(parameters) == sorted(expected), (
            f"{where}: Parameters document {parameters}, the constructor has {expected}")
    for name, method in public_methods(cls):
        if method.__doc__ is None and any(name in vars(base) for base in cls.__mro__[1:]):
            continue  # an override documented where it is declared
        check_callable(method, f"{where}.{name}")


@pytest.mark.parametrize("dotted", api_names())
def test_api_docstring(dotted):
    obj = resolve(dotted)
    if inspect.isclass(obj):
        check_class(obj, dotted)
    else:
        check_callable(obj, dotted)


def test_the_api_page_lists_every_public_name():
    import trigint

    listed = set(api_names())
    for name in trigint.__all__:
        obj = getattr(trigint, name)
        if inspect.ismodule(obj):
            continue
        assert f"trigint.{name}" in listed, f"trigint.{name} is not on docs/api.rst"


def test_the_checks_catch_what_they_are_for():
    """A paragraph inside Parameters, an undocumented parameter and a blank attribute fail."""

    def fake(a, b):
        """Does something.

        Parameters
        ----------
        a : int
        A paragraph that is not a parameter but lands ``here``.
        """

    with pytest.raises(AssertionError, match="is not a parameter name"):
        check_callable(fake, "fake")

    def missing(a, pairs=None):
        """Does something.

        Parameters
        ----------
        a : int
            The a.
        """

    with pytest.raises(AssertionError, match=r"Parameters document \['a'\], the signature has \['a', 'pairs'\]"):
        check_callable(missing, "missing")

    @dataclasses.dataclass
    class Blank:
        """A result.

        Attributes
        ----------
        x : float
        """

        x: float
        y: float

    with pytest.raises(AssertionError, match="attribute 'x' has no description"):
        check_class(Blank, "Blank")
