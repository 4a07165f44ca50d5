"""Scene.edit: the re-solve keeps the hierarchy and equals a fresh solve of the edited scene."""

import numpy as np

import meshrad
from conftest import read_exr

INTENSITY = 300000.0


def test_halving_the_spot_halves_the_probed_light(root):
    scene = meshrad.load(root / "scenes/cornell_box.toml", editable=True)
    points = scene.sample_points(400, seed=5)
    before = meshrad.solve(scene, backend="cpu").probe(points)
    changed = scene.edit(lights={"spot": {"intensity": [INTENSITY / 2] * 3}})
    assert changed["lights"] == ["spot"] and changed["objects"] == []
    after_sol = meshrad.solve(scene, backend="cpu")
    after = after_sol.probe(points)
    assert after_sol.stats["changed"]["rebuild"] is False
    for key in ("direct", "indirect", "total"):
        lit = before[key] > 0
        assert lit.sum() > 300, key
        np.testing.assert_allclose(after[key][lit], before[key][lit] / 2, rtol=1e-6, err_msg=key)


def parts_with(tmp_path, root, name, tallbox="", shortbox="", intensity=None):
    """scenes/cornell_parts.toml with these keys added to the blocks' tables (and the
    spot's intensity), its mesh path made absolute: the edited scene as a file."""
    text = (root / "scenes/cornell_parts.toml").read_text()
    text = text.replace('"cornell_original_mm.obj"', f'"{root / "scenes/cornell_original_mm.obj"}"')
    text = text.replace('group = "cbox_largebox"', f'group = "cbox_largebox"\n{tallbox}')
    text = text.replace('group = "cbox_smallbox"', f'group = "cbox_smallbox"\n{shortbox}')
    if intensity is not None:
        text = text.replace("intensity = [300000.0, 300000.0, 300000.0]", f"intensity = {intensity}")
    path = tmp_path / name
    path.write_text(text)
    return path


def test_an_edit_then_a_solve_equals_a_fresh_solve(root, cli, tmp_path):
    scene = meshrad.Scene.embedded("cornell_parts.toml")
    assert scene.objects == ["room", "shortbox", "tallbox"] and scene.lights == ["spot"]
    first = meshrad.solve(scene, backend="cpu")
    # The first edit: the solve builds the editing hierarchy (reach = "object").
    scene.edit(
        objects={"tallbox": {"rotate": [0.0, 25.0, 0.0], "translate": [-114.03, 0.0, 188.66]}},
        lights={"spot": {"intensity": [2.0e5, 1.5e5, 1.0e5]}},
    )
    edited = meshrad.solve(scene, backend="cpu")
    changed = edited.stats["changed"]
    assert changed["objects"] == ["tallbox"] and changed["lights"] == ["spot"] and changed["rebuild"]
    turned = "rotate = [0.0, 25.0, 0.0]\ntranslate = [-114.03, 0.0, 188.66]"
    one = parts_with(tmp_path, root, "one.toml", tallbox=turned, intensity="[200000.0, 150000.0, 100000.0]")
    fresh = meshrad.solve(meshrad.load(one), backend="cpu")
    for name in ("direct", "indirect", "total"):
        assert np.array_equal(edited.images()[name], fresh.images()[name]), name
    # The second: the hierarchy is kept, only the moved block's clips computed again.
    scene.edit(objects={"shortbox": {"translate": [0.0, 0.0, 60.0]}})
    kept = meshrad.solve(scene, backend="cpu")
    changed = kept.stats["changed"]
    assert changed["objects"] == ["shortbox"] and not changed["rebuild"]
    assert 0 < changed["clips_computed"] < kept.stats["hierarchy"]["nodes_per_level"][-1]
    two = parts_with(tmp_path, root, "two.toml", tallbox=turned, shortbox="translate = [0.0, 0.0, 60.0]",
                     intensity="[200000.0, 150000.0, 100000.0]")
    fresh = meshrad.solve(meshrad.load(two), backend="cpu")
    for name in ("direct", "indirect", "total"):
        assert np.array_equal(kept.images()[name], fresh.images()[name]), name
    cli("solve", two, "--backend", "cpu", "--out", tmp_path / "cli", "-q")
    assert np.array_equal(kept.images()["total"], read_exr(tmp_path / "cli" / "total.exr"))
    # Earlier solutions are theirs still.
    assert not np.array_equal(first.images()["total"], kept.images()["total"])
    assert not np.array_equal(edited.images()["total"], kept.images()["total"])


def test_a_failed_edit_changes_nothing(root):
    scene = meshrad.Scene.embedded("cornell_parts.toml")
    try:
        scene.edit(objects={"tallbox": {"translate": [1.0, 2.0, 3.0]}, "nosuch": {"scale": 2.0}})
    except meshrad.Error as e:
        assert "nosuch" in str(e)
    else:
        raise AssertionError("an unknown object was accepted")
    assert not scene.editable
    sol = meshrad.solve(scene, backend="cpu", rays=64)
    again = meshrad.solve(meshrad.Scene.embedded("cornell_parts.toml"), backend="cpu", rays=64)
    assert np.array_equal(sol.images()["total"], again.images()["total"])
