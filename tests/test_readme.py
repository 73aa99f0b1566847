"""The README's "API in ten lines" runs as written (an example that is also a test)."""

from __future__ import annotations

import re
import subprocess
import sys

from conftest import REPO


def test_readme_api_block_runs(tmp_path):
    text = (REPO / "README.md").read_text()
    block = re.search(r"## The API in ten lines.*?```python\n(.*?)```", text, re.S)
    assert block, "README has no API block"
    proc = subprocess.run(
        [sys.executable, "-c", block.group(1)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        env={"MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"},
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "setpoints.csv").is_file()
    tcp_error_m = float(proc.stdout.strip().splitlines()[-1])
    assert 0 < tcp_error_m < 5e-4  # within the servo's 0.5 mm budget
