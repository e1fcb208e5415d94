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


# "Raises kfx.Error ...", "Raises kfx.NumericalError ...", "Raises ValueError ...": what a call raises, and when.
RAISES = re.compile(r"\b[Rr]aises (kfx\.(Error|NumericalError)|[A-Z]\w*Error)\b")
# Callables that take arguments but check none of them, with the reason.
VALIDATES_NOTHING = {
    "kfx.LinearFilterStep": "a record: kfx.LinearFilter checks its steps",
    "kfx.blockdiag.IdenticalSubsystems": "a record: analyze_identical_subsystems checks it",
    "kfx.mismatch.ModelingErrors": "a record: the functions that take it check it against the model",
    "kfx.mismatch.ErrorRanges": "a record: the functions that take it check it against the design",
    "kfx.continuous.log_log_slope": "a fit: NaN when fewer than two points qualify, nothing to reject",
}


def arguments_of(obj):
    """The names of obj's parameters other than self (from pybind11's signature line, else inspect)."""
    first = (obj.__doc__ or "").lstrip().split("\n", 1)[0]
    name = getattr(obj, "__name__", "")
    if getattr(obj, "__text_signature__", None) is None and re.match(rf"^(\d+\. )?{re.escape(name)}\(", first):
        lines = [l for l in obj.__doc__.splitlines() if re.match(rf"^\s*(\d+\. )?{re.escape(name)}\(", l)]
        params = set()
        for line in lines:  # every overload
            inside = line[line.index("(") + 1:line.rindex(")")]
            params |= {p.split(":")[0].strip() for p in re.split(r",\s*(?![^\[]*\])", inside) if p.strip()}
        return sorted(params - {"self", "*args", "**kwargs"})
    try:
        return [p for p in inspect.signature(obj).parameters if p != "self"]
    except (TypeError, ValueError):
        return []


def constructor_of(cls):
    """cls.__init__ if cls defines one that takes arguments (pybind11 result classes have none)."""
    for klass in cls.__mro__:
        if klass is object or not klass.__module__.startswith("kfx"):
            break
        init = vars(klass).get("__init__")
        if isinstance(init, type(object.__init__)):
            return None  # a slot wrapper: pybind11's "no constructor defined"
        if init is not None:
            return init if arguments_of(init) else None
    return None


def validating_callables():
    """(name, docstring) of every public function, method and constructor that takes arguments, the
    methods a class inherits from kfx's own compiled bases included (kfx.KalmanFilter.predict)."""
    for name, obj in public_objects():
        if name.startswith("kfx.plots.") or name in VALIDATES_NOTHING:
            continue  # kfx.plots: matplotlib helpers over results, no input of kfx's to check
        if inspect.isclass(obj):
            if issubclass(obj, BaseException):
                continue
            init = constructor_of(obj)
            if init is not None:
                yield name, (obj.__doc__ or "") + "\n" + (init.__doc__ or "")
            for base in obj.__mro__[1:]:
                if base.__module__.startswith("kfx") and base.__name__.startswith("_"):
                    for member, value in vars(base).items():
                        if not member.startswith("_") and callable(value) and member not in vars(obj):
                            if f"{name}.{member}" not in VALIDATES_NOTHING and arguments_of(value):
                                yield f"{name}.{member}", value.__doc__ or ""
        elif callable(obj) and not isinstance(obj, property) and arguments_of(obj):
            yield name, obj.__doc__ or ""


def test_every_call_that_checks_its_input_says_what_it_raises():
    missing = [name for name, doc in validating_callables() if not RAISES.search(doc)]
    assert not missing, f"{len(missing)} public calls whose docstring has no 'Raises ...': {missing}"


def test_the_raises_check_sees_the_calls_it_should():
    names = dict(validating_callables())
    # functions, methods, constructors, inherited compiled methods; not argument-less calls or plain results
    for name in ("kfx.solve_filter_dare", "kfx.Model", "kfx.KalmanFilter.predict", "kfx.KalmanFilter.update",
                 "kfx.LinearFilter.run", "kfx.blockdiag.simulate_coupled"):
        assert name in names, name
    for name in ("kfx.Summary.brief_report", "kfx.DareSolution", "kfx.paper_ids"):
        assert name not in names, name
    assert RAISES.search("x. Raises kfx.Error if A is not square.") and RAISES.search("(raises kfx.Error)")
    assert not RAISES.search("raises nothing") and not RAISES.search("an exception it raises stops the call")


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
