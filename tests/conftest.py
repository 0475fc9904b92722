import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture(autouse=True)
def _outputs_to_tmp(tmp_path, monkeypatch):
    """Nothing a test writes lands in the repository's figures/ or data/derived/."""
    monkeypatch.setenv("OCPKIT_OUTPUT_DIR", str(tmp_path / "out"))
    yield
