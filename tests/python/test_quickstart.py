"""docs/python.md's quick start runs as written: every ```python block, in order, in one namespace."""
import os
import re

from conftest import ROOT


def test_quickstart_runs(tmp_path, monkeypatch):
    text = open(os.path.join(ROOT, "docs", "python.md")).read()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 4
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for i, code in enumerate(blocks):
        exec(compile(code, f"docs/python.md block {i}", "exec"), namespace)
    assert (tmp_path / "estimate.png").stat().st_size > 0 and (tmp_path / "estimate.svg").stat().st_size > 0
    assert (tmp_path / "covariance.svg").exists()
