# SPDX-License-Identifier: GPL-3.0-or-later
"""examples/first-session.ipynb runs, top to bottom, against a real daemon
(nbclient with a python3 kernel), so it cannot rot."""

from __future__ import annotations

from pathlib import Path

import nbclient
import nbformat

import hdrstereo

from conftest import Daemon

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples/first-session.ipynb"


def test_first_session_notebook_runs(daemon: Daemon, tmp_path: Path,
                                     monkeypatch) -> None:
    # The kernel inherits the environment: the notebook finds the daemon
    # through HDRSTEREO_SERVER, as a user's would; no profile file.
    monkeypatch.setenv("HDRSTEREO_SERVER", daemon.address)
    monkeypatch.setenv("HDRSTEREO_CLIENT_CONFIG", str(tmp_path / "none.toml"))
    # The package this test imports, wherever it is (build tree or installed).
    monkeypatch.setenv("PYTHONPATH", str(Path(hdrstereo.__file__).parents[1]))
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    notebook = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(notebook, timeout=300, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}
                            ).execute()
    outputs = [o for cell in notebook.cells if cell.cell_type == "code"
               for o in cell.get("outputs", [])]
    text = "".join(o.get("text", "") for o in outputs)
    assert "hardware sim" in text
    assert "fused" in text and "simulation" in text  # the metrics table
    assert "of pixels scored" in text
    assert any("image/png" in o.get("data", {}) for o in outputs)  # the plots
    assert not [o for o in outputs if o.get("output_type") == "error"]
