"""Shared fixtures: the repository, the CLI binary the module is compared with, EXR and CSV
readers."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root():
    return ROOT


@pytest.fixture(scope="session")
def cli():
    """Runs the `meshrad` binary (MESHRAD_BIN, default target/release/meshrad: the README's
    first command builds it); a missing binary is a failure, not a skip."""
    exe = pathlib.Path(os.environ.get("MESHRAD_BIN", ROOT / "target" / "release" / "meshrad"))
    assert exe.is_file(), f"{exe}: no meshrad binary (cargo build --release, or set MESHRAD_BIN)"

    def run(*args):
        p = subprocess.run([str(exe), *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        assert p.returncode == 0, f"meshrad {' '.join(map(str, args))} failed:\n{p.stderr}"
        return p

    return run


def read_exr(path):
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, dtype=np.float32)
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float32) for c in "RGB"], -1)


def read_probe_csv(path):
    """The probe CSV's columns as float32 (N, 3) arrays by the module's names."""
    header = pathlib.Path(path).read_text().splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2).astype(np.float32)
    col = {name: data[:, k] for k, name in enumerate(header)}
    return {
        key: np.stack([col[f"{key}_{c}"] for c in "rgb"], -1)
        for key in ("direct", "indirect", "total", "indirect_se", "direct_se")
    }


def write_points(path, points):
    """A points file holding exactly these float32 values (repr of each float32)."""
    pts = np.asarray(points, dtype=np.float32)
    path.write_text("".join(" ".join(repr(float(x)) for x in row) + "\n" for row in pts))
