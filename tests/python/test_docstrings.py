"""Every public name of kfx has a docstring (issue 21): each function, class, method and property of
kfx, its method-family submodules and kfx.plots has text beyond the signature that pybind11 writes;
where a binding wraps a C++ declaration with a doc comment, that comment is in the docstring
(python/gen_cpp_docs.py, python/src/cpp_docs.cpp)."""
import inspect
import re

import pytest

import kfx

MODULES = ("", "blockdiag", "continuous", "mismatch", "reduced", "subspace", "plots")
SIGNATURE = re.compile(r"^\s*(\d+\. )?[A-Za-z_][\w.]*\(.*\)( -> .*)?$")


def text_of(doc):
    """The docstring without pybind11's signature lines."""
    lines = [l for l in (doc or "").splitlines() if not SIGNATURE.match(l) and l.strip() != "Overloaded function."]
    return "\n".join(lines).strip()


def public_objects():
    """(qualified name, object) for every public function and class and their public members."""
    seen = set()
    for mod_name in MODULES:
        module = getattr(kfx, mod_name) if mod_name else kfx
        prefix = f"kfx.{mod_name}." if mod_name else "kfx."
        names = getattr(module, "__all__", None) or [n for n in dir(module) if not n.startswith("_")]
        for name in names:
            obj = getattr(module, name)
            if inspect.ismodule(obj) or isinstance(obj, str) or id(obj) in seen:
                continue
            if not (callable(obj) or inspect.isclass(obj)) or getattr(obj, "__module__", "").startswith(
                    ("numpy", "matplotlib", "typing")) and mod_name == "plots":
                continue
            seen.add(id(obj))
            yield prefix + name, obj
            if inspect.isclass(obj) and not issubclass(obj, BaseException):
                for member, value in vars(obj).items():
                    if member.startswith("_") or not (callable(value) or isinstance(value, property)):
                        continue
                    yield f"{prefix}{name}.{member}", value


def test_every_public_name_has_a_docstring():
    missing = [name for name, obj in public_objects() if len(text_of(obj.__doc__)) < 8]
    assert not missing, f"{len(missing)} public names without a docstring: {missing}"


def test_docstrings_carry_the_cpp_comments():
    # The comment of SolveFilterDare (include/kfx/riccati.hpp) is in kfx.solve_filter_dare's docstring.
    header = open(kfx_header("riccati.hpp"), encoding="utf-8").read()
    assert "relative_residual <= 1e-8" in header
    assert "C++ (include/kfx/riccati.hpp, SolveFilterDare)" in kfx.solve_filter_dare.__doc__
    assert "relative_residual <= 1e-8" in kfx.solve_filter_dare.__doc__
    assert "Raises kfx.Error" in kfx.solve_filter_dare.__doc__
    # Members: a struct field's ///< comment becomes the property's docstring.
    assert "DareSolution::P_pred" in kfx.DareSolution.P_pred.__doc__
    # Classes.
    assert "C++ (include/kfx/kalman_filter.hpp, Estimate)" in kfx.Estimate.__doc__


def test_docstring_check_catches_a_bare_signature():
    # text_of drops exactly pybind11's signature lines: a function documented by its signature only fails.
    assert text_of("spectral_radius(A: numpy.ndarray) -> float\n") == ""
    assert text_of("Overloaded function.\n\n1. f(x: int) -> int\n\n2. f(x: str) -> str\n") == ""
    assert text_of("f(x: int) -> int\n\nThe f of x.\n") == "The f of x."


def kfx_header(name):
    from conftest import ROOT

    return f"{ROOT}/include/kfx/{name}"


@pytest.mark.parametrize("family", MODULES[1:6])
def test_every_family_module_is_documented(family):
    assert len(getattr(kfx, family).__doc__) > 80
