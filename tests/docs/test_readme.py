"""The README's example runs as written, so it cannot rot."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]


@pytest.mark.slow
def test_readme_python_example_runs():
    """The README's example, as written: 600 frames of the dust devil (about 200,000
    particles on llvmpipe), so slow."""
    readme = (ROOT / "README.md").read_text()
    (example,) = re.findall(r"```python\n(.*?)```", readme, re.S)
    result = subprocess.run([sys.executable, "-c", example], cwd=ROOT, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    live, digest = result.stdout.split()
    assert int(live) > 1000 and re.fullmatch(r"[0-9a-f]{32}", digest)
