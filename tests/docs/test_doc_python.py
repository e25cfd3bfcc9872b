"""The docs' Python example runs as written, so it cannot rot."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[2]
DESIGN = ROOT / "docs/design.md"


@pytest.mark.slow
def test_the_design_python_example_runs():
    """The example, as written: 600 frames of the dust devil (about 200,000 particles on
    llvmpipe), so slow."""
    (example,) = re.findall(r"```python\n(.*?)```", DESIGN.read_text(), re.S)
    result = subprocess.run([sys.executable, "-c", example], cwd=ROOT, capture_output=True,
                            text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    live, digest = result.stdout.split()
    assert int(live) > 1000 and re.fullmatch(r"[0-9a-f]{32}", digest)
