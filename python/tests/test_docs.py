"""The package docstring's example runs, and every public name has a docstring."""

import doctest

import tandem


def test_module_docstring_example():
    result = doctest.testmod(tandem, optionflags=doctest.ELLIPSIS)
    assert result.attempted >= 3 and result.failed == 0


def test_docstrings():
    for name in tandem.__all__:
        obj = getattr(tandem, name)
        if callable(obj):
            assert obj.__doc__, name
    for cls in (tandem.Scenario, tandem.Run):
        for attr in ["run", "with_", "to_toml", "preset", "from_toml", "load", "get"] if cls is tandem.Scenario else ["write", "to_pandas", "summary", "timeseries"]:
            assert getattr(cls, attr).__doc__, f"{cls.__name__}.{attr}"
