"""The module against the CLI: the same scene and keys on the CPU backend give the CLI's
EXR values, probe CSV values, PLY columns and files, bit for bit."""

import json

import numpy as np
import pytest

import meshrad
from conftest import read_exr, read_probe_csv, write_points

SCENE = "scenes/cornell_box.toml"


@pytest.fixture(scope="module")
def solved(root):
    scene = meshrad.load(root / SCENE)
    return scene, meshrad.solve(scene, backend="cpu")


def test_images_equal_the_cli_exr(solved, cli, tmp_path, root):
    _, sol = solved
    cli("solve", SCENE, "--backend", "cpu", "--out", tmp_path / "cli", "-q")
    images = sol.images()
    for name in ("direct", "indirect", "total"):
        exr = read_exr(tmp_path / "cli" / f"{name}.exr")
        img = images[name]
        assert img.dtype == np.float32 and img.shape == (256, 256, 3)
        assert np.array_equal(img, exr), f"{name}: {np.abs(img - exr).max()} off"
    assert images["total"].max() > 0 and images["indirect"].mean() > 0


def test_written_files_equal_the_cli_files(solved, cli, tmp_path):
    _, sol = solved
    cli("solve", SCENE, "--backend", "cpu", "--out", tmp_path / "cli", "--export-nodes", tmp_path / "cli.ply", "-q")
    written = sol.write(tmp_path / "py", export_nodes=tmp_path / "py.ply")
    assert len(written) == 8
    for f in ("direct.exr", "indirect.exr", "total.exr", "direct.png", "indirect.png", "total.png"):
        assert (tmp_path / "py" / f).read_bytes() == (tmp_path / "cli" / f).read_bytes(), f
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()

    def untimed(v):
        if isinstance(v, dict):
            return {k: untimed(x) for k, x in v.items() if "seconds" not in k}
        if isinstance(v, list):
            return [untimed(x) for x in v]
        return v

    cli_stats = json.loads((tmp_path / "cli" / "stats.json").read_text())
    py_stats = json.loads((tmp_path / "py" / "stats.json").read_text())
    # The CLI was given the path relative to the repository; the module, absolute.
    cli_stats["scene"].pop("path"), py_stats["scene"].pop("path")
    cli_stats["scene"]["load"].pop("inputs"), py_stats["scene"]["load"].pop("inputs")
    assert untimed(py_stats) == untimed(cli_stats)
    assert untimed(sol.stats)["solve"] == untimed(cli_stats)["solve"]


def test_probe_values_equal_the_cli_csv(solved, cli, tmp_path):
    scene, sol = solved
    points = scene.sample_points(300, seed=11)
    assert points.shape == (300, 6) and points.dtype == np.float32
    write_points(tmp_path / "p.txt", points)
    cli("probe", SCENE, "--points", tmp_path / "p.txt", "--out", tmp_path / "p.csv", "--backend", "cpu", "-q")
    want = read_probe_csv(tmp_path / "p.csv")
    got = sol.probe(points)
    for key in ("direct", "indirect", "total", "indirect_se", "direct_se"):
        assert got[key].dtype == np.float32 and got[key].shape == (300, 3)
        assert np.array_equal(got[key], want[key]), f"{key}: {np.abs(got[key] - want[key]).max()} off"
    # A list of rows and one row alone are points too.
    one = sol.probe(points[0].tolist())
    assert np.array_equal(one["total"][0], got["total"][0])


def test_nodes_are_the_ply_columns(solved, cli, tmp_path):
    _, sol = solved
    cli("solve", SCENE, "--backend", "cpu", "--out", tmp_path / "o", "--export-nodes", tmp_path / "n.ply", "-q")
    raw = (tmp_path / "n.ply").read_bytes()
    head, body = raw.split(b"end_header\n", 1)
    count = int(head.split(b"element vertex ")[1].split(b"\n")[0])
    rec = np.dtype([("p", "<f4", 3), ("n", "<f4", 3), ("level", "<i4"), ("radius", "<f4"), ("ed", "<f4", 3), ("eind", "<f4", 3)])
    ply = np.frombuffer(body, dtype=rec, count=count)
    nodes = sol.nodes()
    assert nodes["position"].shape == (count, 3)
    assert np.array_equal(nodes["position"], ply["p"]) and np.array_equal(nodes["normal"], ply["n"])
    assert np.array_equal(nodes["level"], ply["level"]) and np.array_equal(nodes["radius"], ply["radius"])
    assert np.array_equal(nodes["E_d"], ply["ed"]) and np.array_equal(nodes["E_ind"], ply["eind"])
    assert set(np.unique(nodes["level"])) == set(range(sol.stats["params"]["levels"]))


def test_solver_keys_are_the_cli_set(root, cli, tmp_path):
    scene = meshrad.Scene.embedded()
    sol = meshrad.solve(scene, backend="cpu", rays=64, bounces=2, variant="modified", eps_rel=0.2)
    cli("solve", "--backend", "cpu", "--rays", "64", "--bounces", "2", "--variant", "modified",
        "--set", "eps_rel=0.2", "--out", tmp_path / "k", "-q")
    assert np.array_equal(sol.images()["total"], read_exr(tmp_path / "k" / "total.exr"))
    p = sol.stats["params"]
    assert (p["rays"], p["bounces"], p["variant"], p["eps_rel"]) == (64, 2, "modified", 0.2)
    # A key the loader reads (final_gather sizes the emitters' sample set) loads the scene
    # again: the same as the CLI given it.
    points = scene.sample_points(50, seed=2)
    write_points(tmp_path / "q.txt", points)
    got = meshrad.solve(scene, backend="cpu", rays=64, final_gather=256).probe(points)
    cli("probe", SCENE, "--points", tmp_path / "q.txt", "--out", tmp_path / "q.csv", "--backend", "cpu",
        "--rays", "64", "--set", "final_gather=256", "-q")
    want = read_probe_csv(tmp_path / "q.csv")
    assert np.array_equal(got["indirect"], want["indirect"])
